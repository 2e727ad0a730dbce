# tests/cli_common.sh: what the test_cli*.sh scripts share (sourced; $1 is the tandem binary):
# check(), a temporary directory removed on exit, the source tree, Debian's python3.
set -u
T="$1"
pass=0
fail=0
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

check() { # check NAME CONDITION-EXIT-STATUS
    # (the seconds since the script began: where a test's minutes go, in CI's log)
    if [ "$2" -eq 0 ]; then pass=$((pass + 1)); echo "ok   $1  [${SECONDS} s]"; else
        fail=$((fail + 1)); echo "FAIL $1  [${SECONDS} s]"; fi
}

SRC=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
PY=python3; [ -x /usr/bin/python3 ] && PY=/usr/bin/python3   # Debian's, with numpy and OpenImageIO
