// Drives the sequencer's supervisor page in headless Chromium, as a person on the robot's
// touch screen would. Run by tests/gui_browser.rs:
//   node drive.mjs URL RELEASE_FILE SCREENSHOT_DIR
// The mission's first state waits for RELEASE_FILE; its second crashes into recovery, after
// which the sequencer asks the supervisor. The script sees the first state highlighted,
// releases it, sees the question arrive without a reload, taps `queue`, and sees the mission
// finish. Beside the question it sees the robot the test feeds: on the map and moving, its
// camera frame, the bindings with their health; it taps "registered" (the answer for the
// robot's Speech provider). Exits non-zero with a message on the first expectation that fails.
import { chromium } from "playwright-core";
import { mkdtempSync, writeFileSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

const [url, release, shots] = process.argv.slice(2);
if (!url || !release || !shots) {
  console.error("usage: node drive.mjs URL RELEASE_FILE SCREENSHOT_DIR");
  process.exit(2);
}
const executablePath = process.env.LEWIS_CHROMIUM || "/usr/bin/chromium";
const profile = mkdtempSync(join(tmpdir(), "lewis-seq-chromium-"));
const step = (what) => console.log(`gui-test: ${what}`);

const context = await chromium.launchPersistentContext(profile, {
  executablePath,
  headless: true,
  args: ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--no-first-run"],
  viewport: { width: 1280, height: 800 },
  hasTouch: true,
  isMobile: false,
  timeout: 30000,
});
let failed = false;
try {
  const page = context.pages()[0] ?? await context.newPage();
  page.setDefaultTimeout(20000);
  page.on("pageerror", (e) => { console.error(`gui-test: page error: ${e}`); failed = true; });
  page.on("dialog", (d) => { console.error(`gui-test: unexpected dialog: ${d.message()}`); failed = true; d.dismiss(); });

  await page.goto(url);
  await page.evaluate(() => { window.__sameDocument = true; });
  await page.locator('#status[data-phase="running"]').waitFor();
  await page.locator('#diagram .box.current[data-state="door"]').waitFor();
  await page.locator("#history li.start", { hasText: "start at door" }).waitFor();
  step("the page shows `door` running");
  await page.screenshot({ path: join(shots, "running.png") });

  writeFileSync(release, "");
  await page.locator('#status[data-phase="asking"]').waitFor();
  const help = page.locator("#help");
  await help.waitFor({ state: "visible" });
  await page.locator("#history li.restart").first().waitFor();
  await page.locator("#history li.recovery").first().waitFor();
  step("the question arrived live, after the restart and the recovery");
  const suggested = await page.locator("#choices .choice.suggested").getAttribute("data-choice");
  if (suggested !== "stop") throw new Error(`the suggested choice is ${suggested}, not stop`);
  const box = await page.locator('#choices [data-choice="queue"]').boundingBox();
  if (!box || box.height < 72 || box.width < 120) {
    throw new Error(`the queue button is too small for a finger: ${JSON.stringify(box)}`);
  }

  // The robot beside the question: the map with the robot moving on it, the camera, who
  // serves what.
  await page.locator("#robot").waitFor({ state: "visible" });
  await page.locator("#map-image").waitFor({ state: "attached" });
  const robotAt = () => page.locator("#map-robot").getAttribute("data-x");
  await page.locator('#map-robot[visibility="visible"]').waitFor({ state: "attached" });
  const x1 = await robotAt();
  await page.waitForFunction((x) => document.querySelector("#map-robot").dataset.x !== x, x1);
  const mapLoaded = await page.evaluate(() => new Promise((resolve) => {
    const probe = new Image();
    probe.onload = () => resolve(probe.naturalWidth);
    probe.onerror = () => resolve(0);
    probe.src = "map.png";
  }));
  if (mapLoaded !== 800) throw new Error(`the map did not load: width ${mapLoaded}`);
  await page.waitForFunction(() => {
    const img = document.querySelector("#camera-img");
    return img.complete && img.naturalWidth === 64 && img.naturalHeight === 48;
  });
  await page.locator('#bindings li.ok[data-interface="RangeFinder"][data-service="sonar"]').waitFor();
  await page.locator('#bindings li.failed[data-service="laser"]').waitFor();
  step("beside the question the page shows the robot moving on the map, its camera and its bindings");
  await page.screenshot({ path: join(shots, "asking.png") });
  await page.locator("#answer").tap();
  await page.locator("#answer-note", { hasText: "answering `yes`" }).waitFor();
  step("the registered answer was sent");
  // A 7-inch panel, as on many robots: the buttons stay finger-sized.
  await page.setViewportSize({ width: 800, height: 480 });
  const small = await page.locator('#choices [data-choice="queue"]').boundingBox();
  if (!small || small.height < 72 || small.width < 120) {
    throw new Error(`on 800x480 the queue button is too small for a finger: ${JSON.stringify(small)}`);
  }
  await page.screenshot({ path: join(shots, "asking-800x480.png") });
  await page.setViewportSize({ width: 1280, height: 800 });

  await page.locator('#choices [data-choice="queue"]').tap();
  await page.locator('#status[data-phase="finished"]').waitFor();
  await page.locator("#history li.resume", { hasText: "resume at queue" }).waitFor();
  await page.locator("#history li.transition", { hasText: "transition register -> stop" }).waitFor();
  await page.locator("#diagram .stopnode.reached").waitFor();
  await page.locator("#outcome", { hasText: "The mission reached stop" }).waitFor();
  await page.locator("#history li.start", { hasText: "start at door" }).waitFor();
  step("after the tap on `queue` the mission resumed there and finished");
  if (!(await page.evaluate(() => window.__sameDocument === true))) {
    throw new Error("the page was reloaded: updates must arrive live");
  }
  await page.screenshot({ path: join(shots, "finished.png") });
  if (failed) throw new Error("the page reported errors (see above)");
  step("ok");
} catch (e) {
  console.error(`gui-test: FAILED: ${e.message ?? e}`);
  failed = true;
} finally {
  await context.close();
  rmSync(profile, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
