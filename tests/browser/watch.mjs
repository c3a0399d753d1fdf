// Opens the viewer in headless Chromium and watches until the server closes it (for
// tests/bench/viewer_cost.sh): node watch.mjs URL#token=…  → prints "watch: open" once the page
// has its hello and scene, and at the end the frames the page drew and its lag behind the
// newest frame the master reported.
import puppeteer from 'puppeteer-core';

const browser = await puppeteer.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium', headless: true,
  args: ['--no-sandbox', '--disable-gpu'] });
try {
  const page = await browser.newPage();
  page.on('console', (m) => { if (m.type() === 'error') console.log(`watch: console error: ${m.text()}`); });
  await page.goto(process.argv[2]);
  const deadline = Date.now() + 30 * 60 * 1000;  // bounded: half an hour at most
  let announced = false;
  for (;;) {
    const s = await page.evaluate(() => ({ drawn: rtpmViewer.framesDrawn, open: !!rtpmViewer.ws,
      ready: !!rtpmViewer.scene, lag: rtpmViewer.lag || { n: 0, sum: 0, max: 0 } }));
    if (s.ready && !announced) {
      console.log('watch: open');
      announced = true;
    }
    if ((announced && !s.open) || Date.now() > deadline) {
      const mean = s.lag.n ? s.lag.sum / s.lag.n : 0;
      console.log(`watch: the page drew ${s.drawn} frames; page-side lag behind the master's newest reported frame ` +
        `mean ${mean.toFixed(2)} max ${s.lag.max} frames`);
      break;
    }
    await new Promise((r) => setTimeout(r, 100));
  }
} finally {
  await browser.close();
}
