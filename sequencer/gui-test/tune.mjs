// Drives `lewis tune open`'s page in headless Chromium. Run by tests/tests/tune_open.rs
// (crate lewis-tests):
//   node tune.mjs URL OUT_DIR
// On a recording of the simulated robot, the script finds a frame with the red cap's blob,
// drags the Red class's V-low slider to the top and sees the blob go from the frame (and
// its plot) without a reload, clicks and drags on the cap's pixels and sees Red's ranges
// refitted to hold them and the blob back, and saves. It writes the YUV values it marked
// to OUT_DIR/marked.json for the test to check against the saved file, and screenshots
// (first.png, slider.png, marked.png) to OUT_DIR. Exits non-zero on the first expectation
// that fails.
import { runInBrowser, sameDocument, step } from "./browser.mjs";
import { writeFileSync } from "node:fs";
import { join } from "node:path";

const [url, out] = process.argv.slice(2);
if (!url || !out) {
  console.error("usage: node tune.mjs URL OUT_DIR");
  process.exit(2);
}

const RED = 0;

/** The Red blobs of frame `i`, as the server finds them. */
const redBlobs = (page, i) => page.evaluate(async ([i, red]) => {
  const f = await (await fetch(`/api/frame/${i}`)).json();
  return f.blobs.filter((b) => b.class === red);
}, [i, RED]);

/** Waits for the frame image to be drawn again after `before` draws. */
const redrawn = (page, before) => page.waitForFunction(
  (n) => Number(document.querySelector("#frame").dataset.drawn || 0) > n, before);
const drawCount = (page) => page.evaluate(() => Number(document.querySelector("#frame").dataset.drawn || 0));

await runInBrowser(url, async (page) => {
  const started = Date.now();
  await page.locator("#frame[data-drawn]").waitFor();
  step(`the first frame is drawn ${Date.now() - started} ms after the page opened`);
  // The whole recording is read, and each class has its plot.
  await page.waitForFunction(() => document.querySelector("#status").textContent.includes("frames held"));
  const frames = await page.evaluate(async () => (await (await fetch("/api/state")).json()).frames.length);
  await page.waitForFunction(() => document.querySelectorAll("#plots svg").length >= 6);
  await page.screenshot({ path: join(out, "first.png") });

  // A frame with the cap, the largest blob of Red.
  let best = null;
  for (let i = 0; i < frames; i++) {
    for (const b of await redBlobs(page, i)) {
      if (!best || b.area_px > best.blob.area_px) best = { frame: i, blob: b };
    }
  }
  if (!best) throw new Error(`no frame of ${frames} has a Red blob with the shipped colours`);
  let before = await drawCount(page);
  await page.locator("#timeline").fill(String(best.frame));
  await redrawn(page, before);
  await page.locator("#blobs", { hasText: "Red " }).waitFor();
  step(`frame ${best.frame} shows the red cap (${best.blob.area_px} px)`);

  // Drag Red's V-low slider to the top: no red pixel is left in the class.
  const slider = page.locator(`input[data-class="${RED}"][data-channel="v"][data-end="lo"]`);
  const box = await slider.boundingBox();
  const value = Number(await slider.inputValue());
  before = await drawCount(page);
  await page.mouse.move(box.x + (box.width * value) / 255, box.y + box.height / 2);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width * 0.8, box.y + box.height / 2, { steps: 5 });
  await page.mouse.move(box.x + box.width + 20, box.y + box.height / 2, { steps: 5 });
  await page.mouse.up();
  if (Number(await slider.inputValue()) !== 255) throw new Error(`the slider is at ${await slider.inputValue()}, not 255`);
  await redrawn(page, before);
  await page.waitForFunction(() => /Red 0/.test(document.querySelector("#blobs").textContent));
  await page.waitForFunction((red) => {
    const svg = document.querySelector(`#plots svg[data-class="${red}"]`);
    return svg && svg.dataset.blobs.split(",").every((n) => n === "0");
  }, RED);
  if ((await redBlobs(page, best.frame)).length !== 0) throw new Error("the server still finds Red blobs");
  await sameDocument(page);
  step("dragging Red's V-low slider to 255 took the cap's blob off the frame and its plot, without a reload");
  await page.screenshot({ path: join(out, "slider.png") });

  // Mark the cap's pixels as Red: a click on its centroid, then a drag over its middle.
  await page.locator(`#class-${RED} input[type=radio]`).check();
  const img = await page.locator("#frame").boundingBox();
  const natural = await page.evaluate(async (i) => (await (await fetch("/api/state")).json()).frames[i].width, best.frame);
  const scale = img.width / natural;
  const [cx, cy] = best.blob.centroid;
  const at = (x, y) => [img.x + (x + 0.5) * scale, img.y + (y + 0.5) * scale];
  const marked = [];
  const collect = async (action) => {
    const response = page.waitForResponse((r) => r.url().endsWith("/api/mark"));
    await action();
    const r = await response;
    if (!r.ok()) throw new Error(`marking failed: ${r.status()} ${await r.text()}`);
    marked.push(...(await r.json()).marked);
  };
  const [b0, b1, b2, b3] = best.blob.box;
  await collect(() => page.mouse.click(...at(Math.round(cx), Math.round(cy))));
  // The middle half of the blob's box.
  const qx = (b2 - b0) / 4, qy = (b3 - b1) / 4;
  await collect(async () => {
    await page.mouse.move(...at(Math.round(cx - qx), Math.round(cy - qy)));
    await page.mouse.down();
    await page.mouse.move(...at(Math.round(cx + qx), Math.round(cy + qy)), { steps: 4 });
    await page.mouse.up();
  });
  step(`marked ${marked.length} pixels around ${best.blob.centroid} in box ${best.blob.box}`);
  // One pixel for the click, the middle of the box for the drag: fewer than the box has.
  if (marked.length < 2 || marked.length > (b2 - b0 + 1) * (b3 - b1 + 1)) {
    throw new Error(`${marked.length} pixels marked, not a click and the middle of the cap`);
  }
  await page.waitForFunction(() => /Red [1-9]/.test(document.querySelector("#blobs").textContent));
  const ranges = JSON.parse(await page.locator(`#class-${RED}`).getAttribute("data-ranges"));
  for (const p of marked) {
    for (let c = 0; c < 3; c++) {
      if (p[c] < ranges[c][0] || p[c] > ranges[c][1]) {
        throw new Error(`marked pixel ${p} is outside the refitted ranges ${JSON.stringify(ranges)}`);
      }
    }
  }
  if (Number(await slider.inputValue()) === 255) throw new Error("the V-low slider did not move to the refit");
  await page.locator(`#samples-${RED}`, { hasText: `(${marked.length} in, 0 out)` }).waitFor();
  await sameDocument(page);
  step(`marking ${marked.length} pixels of the cap refitted Red to ${JSON.stringify(ranges)}, and the blob is back`);
  await page.screenshot({ path: join(out, "marked.png") });

  await page.locator("#save").click();
  await page.locator("#save-status[data-saved]").waitFor();
  writeFileSync(join(out, "marked.json"), JSON.stringify(marked));
  step(`saved to ${await page.locator("#save-status").getAttribute("data-saved")}`);
});
