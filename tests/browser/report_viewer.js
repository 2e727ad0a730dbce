// tests/browser/report_viewer.js REPORT_DIR [SCREENSHOT.png]: the report you can watch
// (REPORT_DIR/viewer.html, written by `tandem eval --report`) in Debian's headless Chromium,
// driven by puppeteer-core: it loads, the scrubber steps, the swipe moves, side by side zooms
// both panes together, the exposure slider and the plots work, play advances the frames, the
// error and FLIP views show, and no console error, page error or failed request appears.
"use strict";
const path = require("path");
const puppeteer = require("puppeteer-core");

const dir = path.resolve(process.argv[2]);
const shot = process.argv[3];
let failures = 0;
function check(name, ok, detail) {
  console.log((ok ? "ok   " : "FAIL ") + name + (detail ? "  (" + detail + ")" : ""));
  if (!ok) failures++;
}

(async () => {
  const browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    headless: true,
    args: ["--no-sandbox", "--disable-gpu"],
  });
  try {
    const page = await browser.newPage();
    const problems = [];
    page.on("console", (m) => { if (m.type() === "error") problems.push("console: " + m.text()); });
    page.on("pageerror", (e) => problems.push("page error: " + e.message));
    page.on("requestfailed", (r) => problems.push("failed request: " + r.url()));
    await page.setViewport({ width: 1300, height: 1000 });
    await page.goto("file://" + path.join(dir, "viewer.html"));
    await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
    const attr = (a) => page.$eval("body", (b, a) => b.getAttribute(a), a);
    const waitAttr = (a, pred, ms = 10000) =>
      page.waitForFunction((a, src) => new Function("v", "return " + src)(document.body.getAttribute(a)),
                           { timeout: ms }, a, pred);
    const n = await page.evaluate(() => window.TND_REPORT.frames.length);
    check("the viewer loads its report (" + n + " frames)", n >= 4);

    // the scrubber: another frame, another picture
    const h0 = await attr("data-shown");
    await page.$eval("#scrub", (s) => { s.value = "3"; s.dispatchEvent(new Event("input")); });
    await waitAttr("data-frame", "v === '3'");
    await waitAttr("data-shown", "v !== " + JSON.stringify(h0));
    check("stepping the scrubber shows frame 3, a different picture", (await attr("data-frame")) === "3");

    // the swipe: dragging the split line changes what is shown
    const c = await (await page.$("#view0")).boundingBox();
    const hs = await attr("data-shown");
    await page.mouse.move(c.x + c.width * 0.5, c.y + c.height * 0.5);
    await page.mouse.down();
    await page.mouse.move(c.x + c.width * 0.1, c.y + c.height * 0.5, { steps: 5 });
    await page.mouse.up();
    const hw = await attr("data-shown");
    check("dragging the A/B swipe line changes the picture", hw !== hs);

    // side by side, zoom linked across the panes
    await page.select("#mode", "side");
    const visible = await page.$eval("#view1", (v) => v.offsetParent !== null);
    const before = await page.$eval("#view1", (v) => v.toDataURL());
    await page.mouse.move(c.x + c.width * 0.3, c.y + c.height * 0.3);
    await page.mouse.wheel({ deltaY: -300 });
    await waitAttr("data-zoom", "+v > 1");
    const after = await page.$eval("#view1", (v) => v.toDataURL());
    check("side by side: zooming one pane zooms the other", visible && before !== after,
          "zoom " + (await attr("data-zoom")));

    // exposure
    const he = await attr("data-shown");
    await page.$eval("#ev", (s) => { s.value = "2"; s.dispatchEvent(new Event("input")); });
    check("the exposure slider re-tone-maps the frame", (await attr("data-shown")) !== he);

    // a click on a plot shows that frame
    const plot = await (await page.$("#plots canvas")).boundingBox();
    await page.mouse.click(plot.x + plot.width - 10, plot.y + plot.height / 2);
    await waitAttr("data-frame", "v === '" + (n - 1) + "'");
    check("clicking a plot near its end shows the last frame", (await attr("data-frame")) === String(n - 1));

    // play advances, pause stops (the frame paused on is not asked to be other than 0: the
    // playback loops, and on a loaded machine it went round between the two clicks)
    await page.$eval("#scrub", (s) => { s.value = "0"; s.dispatchEvent(new Event("input")); });
    await page.click("#play");
    await waitAttr("data-frame", "v !== '0'", 10000); /* (throws if play never advances) */
    await page.click("#play");
    await waitAttr("data-playing", "v === '0'");
    const held = await attr("data-frame");
    await new Promise((r) => setTimeout(r, 400));
    check("play advances the frames, pause holds one", (await attr("data-playing")) === "0" &&
          (await attr("data-frame")) === held);

    // the error and FLIP views
    await page.select("#mode", "error");
    const herr = await attr("data-shown");
    check("the false-colour error view draws", herr && herr !== "flip");
    await page.select("#mode", "flip");
    await waitAttr("data-shown", "v === 'flip'"); /* (set once the map has loaded and is drawn) */
    check("the FLIP view shows the frame's FLIP map", (await attr("data-shown")) === "flip");
    await page.select("#mode", "swipe");
    if (shot) await page.screenshot({ path: shot });
    const errs = await attr("data-errors");
    check("no console error, page error or failed request", problems.length === 0 && !errs,
          problems.concat(errs ? [errs] : []).join("; "));
  } catch (e) {
    check("the browser session", false, e.message);
  } finally {
    await browser.close();
  }
  process.exit(failures ? 1 : 0);
})();
