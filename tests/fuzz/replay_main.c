/* tests/fuzz/replay_main.c: a fuzz target's inputs replayed without libFuzzer (the normal and
 * sanitizer builds): every file named, or every file in the directories named, through
 * LLVMFuzzerTestOneInput once. tests/fuzz/regressions.sh runs it on regressions/<target>/. */
#include "tests/fuzz/fuzz_common.h"

#include <dirent.h>

static int run_file(const char *path)
{
    void *data = NULL;
    size_t size = 0;
    if (tnd_file_read(path, &data, &size) != TND_OK) {
        fprintf(stderr, "replay: %s: %s\n", path, tnd_error_detail());
        return 1;
    }
    LLVMFuzzerTestOneInput(data, size);
    free(data);
    return 0;
}

int main(int argc, char **argv)
{
    int bad = 0, n = 0;
    for (int i = 1; i < argc; i++) {
        DIR *d = opendir(argv[i]);
        if (!d) {
            bad |= run_file(argv[i]);
            n++;
            continue;
        }
        for (struct dirent *e; (e = readdir(d));) {
            if (e->d_name[0] == '.' || strcmp(e->d_name, "README.md") == 0)
                continue;
            char path[4096];
            snprintf(path, sizeof path, "%s/%s", argv[i], e->d_name);
            bad |= run_file(path);
            n++;
        }
        closedir(d);
    }
    printf("replay: %d inputs\n", n);
    return bad;
}
