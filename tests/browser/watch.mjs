// Opens the viewer in headless Chromium and watches until the server closes it (for
// tests/bench/viewer_cost.sh): node watch.mjs URL#token=…  → prints the frames the page drew.
import puppeteer from 'puppeteer-core';

const browser = await puppeteer.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium', headless: true,
  args: ['--no-sandbox', '--disable-gpu'] });
try {
  const page = await browser.newPage();
  await page.goto(process.argv[2]);
  const deadline = Date.now() + 30 * 60 * 1000;  // bounded: half an hour at most
  for (;;) {
    const s = await page.evaluate(() => ({ drawn: rtpmViewer.framesDrawn, open: !!rtpmViewer.ws }));
    if (!s.open || Date.now() > deadline) {
      console.log(`watch: the page drew ${s.drawn} frames`);
      break;
    }
    await new Promise((r) => setTimeout(r, 200));
  }
} finally {
  await browser.close();
}
