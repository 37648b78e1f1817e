// Drives the sequencer's supervisor page in headless Chromium, as a person on the robot's
// touch screen would. Run by tests/gui_browser.rs:
//   node drive.mjs URL RELEASE_FILE SCREENSHOT_DIR
// The mission's first state waits for RELEASE_FILE; its second crashes into recovery, after
// which the sequencer asks the supervisor. The script sees the first state highlighted,
// releases it, sees the question arrive without a reload, taps `queue`, and sees the mission
// finish. Beside the question it sees the robot the test feeds: on the map and moving, its
// camera frame, the bindings with their health; it taps "registered" (the answer for the
// robot's Speech provider). Exits non-zero with a message on the first expectation that fails.
import { imageWidth, runInBrowser, sameDocument, step } from "./browser.mjs";
import { writeFileSync } from "node:fs";
import { join } from "node:path";

const [url, release, shots] = process.argv.slice(2);
if (!url || !release || !shots) {
  console.error("usage: node drive.mjs URL RELEASE_FILE SCREENSHOT_DIR");
  process.exit(2);
}

await runInBrowser(url, async (page) => {
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
  const mapLoaded = await imageWidth(page, "map.png");
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
  await sameDocument(page);
  await page.screenshot({ path: join(shots, "finished.png") });
});
