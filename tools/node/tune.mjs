// Drives `lewis tune open`'s page in headless Chromium. Run by tests/tests/tune_open.rs
// (crate lewis-tests):
//   node tune.mjs URL OUT_DIR
// On a recording of the simulated robot, the script finds a frame with the red cap's blob,
// drags the Red class's V-low slider to the top and sees the blob go from the frame (and
// its plot) without a reload, clicks and drags on the cap's pixels and sees Red's ranges
// refitted to hold them and the blob back, and saves. Then it labels the cap: a box of class
// Red dragged around it (another box drawn and removed), sees the live score find it, and
// saves the labels. It writes the YUV values it marked to OUT_DIR/marked.json and the box
// it dragged (full-frame px) to OUT_DIR/box.json for the test to check against the saved
// files, and screenshots (first.png, slider.png, marked.png, labelled.png) to OUT_DIR. Exits non-zero on the first expectation
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

  // Label the cap: a box dragged around its blob (in the camera's full-frame pixels, twice
  // the held frame's), of class Red.
  await page.locator("#mode-box").check();
  const state = await page.evaluate(async () => (await fetch("/api/state")).json());
  const [fullW, fullH] = state.frames[best.frame].full;
  const k = img.width / fullW;
  const atFull = (x, y) => [img.x + (x + 0.5) * k, img.y + (y + 0.5) * k];
  const drag = async (from, to) => {
    await page.mouse.move(...atFull(...from));
    await page.mouse.down();
    await page.mouse.move(...atFull(...to), { steps: 6 });
    await page.mouse.up();
  };
  const boxes = () => page.evaluate(() => JSON.parse(document.querySelector("#boxes").dataset.boxes || "[]"));
  const waitBoxes = (n) => page.waitForFunction((n) => JSON.parse(document.querySelector("#boxes").dataset.boxes || "[]").length === n, n);
  // The cap's blob as Red is now (refitted), in held pixels: each is 2x2 camera pixels.
  const now = (await redBlobs(page, best.frame)).reduce((a, b) => (b.area_px > a.area_px ? b : a));
  const [n0, n1, n2, n3] = now.box;
  const dragged = [n0 * 2, n1 * 2, n2 * 2 + 1, n3 * 2 + 1];
  await page.locator("#box-class").selectOption({ label: "Red" });
  await drag([dragged[0], dragged[1]], [dragged[2], dragged[3]]);
  await waitBoxes(1);
  const [cap] = await boxes();
  if (cap.class !== "Red" || cap.box.some((v, i) => Math.abs(v - dragged[i]) > 1)) {
    throw new Error(`the box drawn is ${JSON.stringify(cap)}, not Red at ${dragged}`);
  }
  // A second box, of another class, removed again with its button.
  await page.locator("#box-class").selectOption({ label: "Yellow" });
  // Away from the cap, so as not to start on its box's label.
  const fx = dragged[0] < fullW / 2 ? fullW - 70 : 10, fy = dragged[1] < fullH / 2 ? fullH - 50 : 10;
  await drag([fx, fy], [fx + 50, fy + 30]);
  await waitBoxes(2);
  if ((await boxes())[1].class !== "Yellow") throw new Error(`the second box is ${JSON.stringify(await boxes())}`);
  await page.locator(".label-box .remove-box").nth(1).click();
  await waitBoxes(1);
  await page.waitForFunction((i) => document.querySelector("#labelled").dataset.labelled === String(i), best.frame);
  // The score with Red's refitted ranges: the cap's blob finds the box drawn around it.
  await page.waitForFunction(() => {
    const s = JSON.parse(document.querySelector("#score").dataset.score || "null");
    return s && s.frames === 1 && s.classes.length === 1 && s.classes[0].name === "Red";
  });
  const score = JSON.parse(await page.locator("#score").getAttribute("data-score"));
  if (score.classes[0].found !== 1 || score.classes[0].missed !== 0) {
    throw new Error(`the cap's blob does not find its box: ${JSON.stringify(score)}`);
  }
  await sameDocument(page);
  step(`labelled the cap on frame ${best.frame} as Red at [${cap.box}] (dragged [${dragged}]); score ${JSON.stringify(score.classes[0])}`);
  await page.screenshot({ path: join(out, "labelled.png") });

  await page.locator("#save-labels").click();
  await page.locator("#labels-status[data-saved]").waitFor();
  writeFileSync(join(out, "box.json"), JSON.stringify({ frame: state.frames[best.frame].name, box: dragged }));
  step(`labels saved to ${await page.locator("#labels-status").getAttribute("data-saved")}`);
});
