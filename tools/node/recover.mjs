// The supervisor of a live Robot Challenge mission in headless Chromium, as a person on the
// robot's touch screen would be. Run by tests/tests/challenge_recovery.rs (crate lewis-tests):
//   node recover.mjs URL SCREENSHOT_DIR
// The mission starts at `sign`, whose program the test crashes beyond its restarts; the
// recovery state follows the red cap, and when it is over the sequencer asks. The script
// sees the restarts and the recovery arrive live, then, beside the question, the robot as
// the page shows it: on the world map in the hall (where following the cap from the
// corridor's turn took it), its camera's latest frame, and who serves what; it taps `sign`
// and sees the mission finish through queue and register. Exits non-zero with a message on
// the first expectation that fails.
import { imageWidth, runInBrowser, sameDocument, step } from "./browser.mjs";
import { join } from "node:path";

const [url, shots] = process.argv.slice(2);
if (!url || !shots) {
  console.error("usage: node recover.mjs URL SCREENSHOT_DIR");
  process.exit(2);
}
// The live mission's phases take tens of seconds: the waits for them are longer than the
// default one for what the page must show at once.
const MISSION_PHASE_MS = 120000;

await runInBrowser(url, async (page) => {
  await page.locator("#history li.start", { hasText: "start at sign" }).waitFor();
  step("the page shows the mission started at `sign`");

  // The crashes and the recovery, live.
  await page.locator("#history li.restart").nth(2).waitFor({ timeout: MISSION_PHASE_MS });
  await page.locator("#history li.recovery").first().waitFor({ timeout: MISSION_PHASE_MS });
  // Recovery runs for about 20 s, so the page normally sees it running; a browser slow to
  // start on a loaded machine may see it over already, which is no fault of the page.
  await page.locator('#diagram .box.current[data-state="oops"], #status[data-phase="asking"]')
    .first().waitFor({ timeout: MISSION_PHASE_MS });
  step("`sign` crashed beyond its 3 restarts and the recovery state `oops` ran");
  await page.screenshot({ path: join(shots, "recovering.png") });

  await page.locator('#status[data-phase="asking"]').waitFor({ timeout: MISSION_PHASE_MS });
  await page.locator("#help").waitFor({ state: "visible" });
  const suggested = await page.locator("#choices .choice.suggested").getAttribute("data-choice");
  if (suggested !== "stop") throw new Error(`the suggested choice is ${suggested}, not stop`);
  step("the question arrived live once the recovery was over");

  // The robot beside the question, from the live robot: on the map, in the hall (north of
  // the corridor, y > 17.25 m) and west of where it started, after following the cap.
  await page.locator("#robot").waitFor({ state: "visible" });
  await page.locator('#map-robot[visibility="visible"]').waitFor({ state: "attached" });
  const mapWidth = await imageWidth(page, "map.png");
  if (mapWidth !== 800) throw new Error(`the world's map did not load: width ${mapWidth}`);
  const x = Number(await page.locator("#map-robot").getAttribute("data-x"));
  const y = Number(await page.locator("#map-robot").getAttribute("data-y"));
  if (!(y > 17.25 && x < 27.5)) {
    throw new Error(`the robot is at ${x}, ${y} on the map, not in the hall west of the turn`);
  }
  step(`the map shows the robot in the hall at ${x}, ${y}`);
  await page.waitForFunction(() => {
    const img = document.querySelector("#camera-img");
    return img.complete && img.naturalWidth > 0 && img.naturalWidth * 3 === img.naturalHeight * 4;
  });
  await page.locator("#camera-title", { hasText: "Camera (camera)" }).waitFor();
  await page.locator('#bindings li.ok[data-interface="ImageSource"][data-service="camera"]').first().waitFor();
  await page.locator('#bindings li.ok[data-interface="RangeFinder"][data-service="laser"]').first().waitFor();
  step("the page shows the camera's frame and the bindings, healthy");
  await page.screenshot({ path: join(shots, "asking.png") });

  await page.locator('#choices [data-choice="sign"]').tap();
  await page.locator("#history li.resume", { hasText: "resume at sign" }).waitFor();
  step("tapped `sign`: the mission resumes there");
  await page.locator('#status[data-phase="finished"]').waitFor({ timeout: MISSION_PHASE_MS });
  await page.locator("#history li.transition", { hasText: "transition sign -> queue" }).waitFor();
  await page.locator("#history li.transition", { hasText: "transition register -> stop" }).waitFor();
  await page.locator("#diagram .stopnode.reached").waitFor();
  await page.locator("#outcome", { hasText: "The mission reached stop" }).waitFor();
  step("the mission finished through queue and register");
  await sameDocument(page);
  await page.screenshot({ path: join(shots, "finished.png") });
});
