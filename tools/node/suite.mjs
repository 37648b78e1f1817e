// Opens `lewis test`'s report page (a file, no server) in headless Chromium and checks it
// as a person reads it. Run by tests/tests/suite_cli.rs (crate lewis-tests):
//   node suite.mjs REPORT.html OUT.png
// Checks the verdict heading, one table row per run and per case, that every image the
// page inlines (the sweeps' plots, the runs' pictures) loads, and that the page asks for
// nothing from the network; writes a full-page screenshot to OUT.png.
import { runInBrowser, step } from "./browser.mjs";
import { pathToFileURL } from "node:url";

const [report, shot] = process.argv.slice(2);
if (!report || !shot) {
  console.error("usage: node suite.mjs REPORT.html OUT.png");
  process.exit(2);
}

await runInBrowser(pathToFileURL(report).href, async (page) => {
  const heading = await page.textContent("h1");
  step(`heading: ${heading}`);
  if (!/^lewis test: (passed|failed)$/.test(heading.trim())) {
    throw new Error(`no verdict in the heading: ${heading}`);
  }
  const sections = await page.locator("section").count();
  step(`runs: ${sections}`);
  if (sections === 0) throw new Error("no run on the page");
  const images = await page.evaluate(() => Array.from(document.images).map((i) => ({
    alt: i.alt, width: i.naturalWidth, inline: i.src.startsWith("data:image/png;base64,"),
  })));
  for (const image of images) {
    if (!image.inline) throw new Error(`${image.alt}: not inlined`);
    if (image.width === 0) throw new Error(`${image.alt}: does not load`);
  }
  step(`images: ${images.length}, all inlined and loaded`);
  const external = await page.evaluate(() => performance.getEntriesByType("resource")
    .map((r) => r.name).filter((n) => !n.startsWith("data:")));
  if (external.length > 0) throw new Error(`the page asks for ${external.join(", ")}`);
  await page.screenshot({ path: shot, fullPage: true });
  step(`screenshot: ${shot}`);
});
