// The headless Chromium that the GUI tests drive, set up once for drive.mjs and
// recover.mjs: a throw-away profile, a touch screen, the page's own errors and dialogs
// counted as failures, one `gui-test: ...` line per step, and the exit code.
import { chromium } from "playwright-core";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

/** Prints one step of the test. */
export const step = (what) => console.log(`gui-test: ${what}`);

/**
 * Opens `url` in headless Chromium (LEWIS_CHROMIUM, else /usr/bin/chromium), runs
 * `test(page)`, and exits the process: 0 when it returned and the page reported no error,
 * 1 with a message on the first expectation that failed. The page is marked on load, so
 * `test` can check with `sameDocument(page)` that updates arrived without a reload.
 */
export async function runInBrowser(url, test) {
  const executablePath = process.env.LEWIS_CHROMIUM || "/usr/bin/chromium";
  const profile = mkdtempSync(join(tmpdir(), "lewis-seq-chromium-"));
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
    await test(page);
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
}

/** Throws unless the page is still the document loaded first (no reload). */
export async function sameDocument(page) {
  if (!(await page.evaluate(() => window.__sameDocument === true))) {
    throw new Error("the page was reloaded: updates must arrive live");
  }
}

/** The natural width of the image at `src` as the page loads it, 0 when it does not load. */
export async function imageWidth(page, src) {
  return page.evaluate((src) => new Promise((resolve) => {
    const probe = new Image();
    probe.onload = () => resolve(probe.naturalWidth);
    probe.onerror = () => resolve(0);
    probe.src = src;
  }), src);
}
