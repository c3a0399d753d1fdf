// Opens the viewer in headless Chromium and watches until the server closes it (for
// tests/bench/viewer_cost.sh): node watch.mjs URL#token=… [pages=1] → prints "watch: open" once
// every page has its hello and scene, and at the end the frames each page drew and its lag
// behind the newest frame the master reported.
import puppeteer from 'puppeteer-core';

const pagesWanted = Math.max(1, Math.min(8, Number(process.argv[3] || 1)));
const browser = await puppeteer.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium', headless: true,
  args: ['--no-sandbox', '--disable-gpu'] });
try {
  const pages = [];
  for (let i = 0; i < pagesWanted; i++) {
    // Each page in its own browser context (its own window): tabs of one window would hide all
    // but the front one, and a hidden page receives no frames (viewer.js holds its ack).
    const page = await (await browser.createBrowserContext()).newPage();
    page.on('console', (m) => { if (m.type() === 'error') console.log(`watch: console error: ${m.text()}`); });
    await page.goto(process.argv[2]);
    pages.push(page);
  }
  const deadline = Date.now() + 30 * 60 * 1000;  // bounded: half an hour at most
  let announced = false;
  for (;;) {
    const all = await Promise.all(pages.map((p) => p.evaluate(() => ({ drawn: rtpmViewer.framesDrawn, open: !!rtpmViewer.ws,
      ready: !!rtpmViewer.scene, lag: rtpmViewer.lag || { n: 0, sum: 0, max: 0 } }))));
    if (all.every((s) => s.ready) && !announced) {
      console.log('watch: open');
      announced = true;
    }
    if ((announced && all.every((s) => !s.open)) || Date.now() > deadline) {
      all.forEach((s, i) => {
        const mean = s.lag.n ? s.lag.sum / s.lag.n : 0;
        console.log(`watch: page ${i + 1} drew ${s.drawn} frames; page-side lag behind the master's newest reported frame ` +
          `mean ${mean.toFixed(2)} max ${s.lag.max} frames`);
      });
      break;
    }
    await new Promise((r) => setTimeout(r, 100));
  }
} finally {
  await browser.close();
}
