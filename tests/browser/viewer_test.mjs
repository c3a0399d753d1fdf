// Browser test of rtpm-server's viewer (ctest label `browser`): starts a local cluster with the
// viewer, opens the page in the system's headless Chromium through puppeteer-core (DevTools
// protocol), and checks the live picture, camera and light controls, refusal of a malformed
// control, and that the page logs no console error. Saves a screenshot of the viewer while the
// view converges, before any control is sent (README's picture: copy it to tests/browser/viewer.png).
//
//   node viewer_test.mjs --server rtpm-server --client rtpm-client --work DIR [--screenshot PNG]
//                        [--chromium /usr/bin/chromium] [--width 320 --height 240]
//
// Every wait is bounded; every process started is stopped by PID at the end.
import { spawn } from 'node:child_process';
import { mkdirSync, existsSync } from 'node:fs';
import path from 'node:path';

let puppeteer;
try {
  puppeteer = (await import('puppeteer-core')).default;
} catch {
  console.error('viewer_test: puppeteer-core is missing: run deploy/install-browser-test.sh');
  process.exit(1);
}

const args = Object.fromEntries(process.argv.slice(2).reduce((acc, a, i, all) => {
  if (a.startsWith('--')) acc.push([a.slice(2), all[i + 1]]);
  return acc;
}, []));
for (const need of ['server', 'client', 'work'])
  if (!args[need]) { console.error(`viewer_test: --${need} is required`); process.exit(2); }
const chromium = args.chromium || '/usr/bin/chromium';
mkdirSync(args.work, { recursive: true });

const token = 'browser-test-' + Math.random().toString(16).slice(2);
const children = [];
const failures = [];
const check = (ok, what) => { console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`); if (!ok) failures.push(what); };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function waitFor(what, fn, timeoutMs = 120000) {  // bounded poll, not a timing assertion
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`gave up waiting for ${what}`);
    await sleep(100);
  }
}

function start(bin, argv, name) {
  const p = spawn(bin, argv, { env: { ...process.env, RTPM_TOKEN: token }, stdio: ['ignore', 'pipe', 'pipe'] });
  p.out = '';
  p.stdout.on('data', (d) => { p.out += d; });
  p.stderr.on('data', (d) => { p.err = (p.err || '') + d; });
  // 'close', not 'exit': 'exit' may come before the last of the child's output has been read.
  p.exited = new Promise((r) => p.on('close', (code, sig) => r({ code, sig })));
  p.name = name;
  children.push(p);
  return p;
}

let browser;
let server;
try {
  const portFile = path.join(args.work, 'port');
  server = start(args.server, ['--port', '0', '--port-file', portFile, '--http', '127.0.0.1:0', '--scene', 'RING',
    '--width', args.width || '320', '--height', args.height || '240', '-P', '8000', '--out', path.join(args.work, 'ring.exr'), '--quiet'], 'server');
  const url = await waitFor('the viewer URL', () => /viewer: (http:\/\/\S+)/.exec(server.out)?.[1], 60000);
  await waitFor('the port file', () => existsSync(portFile), 60000);
  for (const n of [1, 2])
    start(args.client, ['--port-file', portFile, '--name', `browser-${n}`, '--threads', '1'], `client ${n}`);

  browser = await puppeteer.launch({ executablePath: chromium, headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--window-size=1200,900'] });
  const page = await browser.newPage();
  await page.setViewport({ width: 1200, height: 900 });
  const consoleErrors = [];
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(String(e)));
  await page.goto(`${url}#token=${token}`);

  const viewer = () => page.evaluate(() => ({
    framesDrawn: rtpmViewer.framesDrawn, lastFrame: rtpmViewer.lastFrame, control: rtpmViewer.control,
    status: rtpmViewer.status, epochs: rtpmViewer.epochs, modes: rtpmViewer.modes, errors: rtpmViewer.errors,
    lag: rtpmViewer.lag,
  }));
  // Luminance statistics of the drawn frame, and the pixels themselves for differences.
  const pixels = () => page.evaluate(() => {
    const c = document.getElementById('frame-canvas');
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    const lum = new Array(d.length / 4);
    for (let i = 0; i < lum.length; i++) lum[i] = 0.2126 * d[4 * i] + 0.7152 * d[4 * i + 1] + 0.0722 * d[4 * i + 2];
    return lum;
  });
  const stats = (lum) => {
    const mean = lum.reduce((a, b) => a + b, 0) / lum.length;
    const sd = Math.sqrt(lum.reduce((a, b) => a + (b - mean) ** 2, 0) / lum.length);
    return { mean, sd };
  };
  const meanAbsDiff = (a, b) => a.reduce((s, v, i) => s + Math.abs(v - b[i]), 0) / a.length;

  // A frame's status travels apart from its picture: wait for both.
  await waitFor('two frames drawn and a status', async () => {
    const v = await viewer();
    return v.framesDrawn >= 2 && v.status;
  });
  const v0 = await viewer();
  check(v0.control, 'the page holds the token: controls are on');
  const first = await pixels();
  const s0 = stats(first);
  check(s0.sd > 10 && s0.mean > 5 && s0.mean < 250, `the picture is not blank (mean ${s0.mean.toFixed(1)}, sd ${s0.sd.toFixed(1)})`);
  // Frames whose client was still busy show their sets' previous values, so wait for later frames
  // with more photons in them: the stored photons doubled, or (progressive estimator, the
  // default) three more passes — a still frame's pass photons refine every pixel's estimate but
  // reach the stored maps only when the progression ends.
  const f0 = v0.lastFrame, p0 = v0.status.photonsPerSet, passes0 = v0.status.passes || 0;
  // The figures of the frame drawn come from its own status (the page keeps the last ones): a
  // page that draws slower than the master composes is rarely at the newest status.
  await waitFor('more photons', async () => {
    const v = await viewer();
    const drawn = v.modes.find((m) => m.frame === v.lastFrame);
    const more = drawn && (drawn.photonsPerSet >= 2 * p0 || (v.status.estimator === 'progressive' && drawn.passes >= passes0 + 3));
    return v.lastFrame >= f0 + 3 && more;
  });
  const later = await pixels();
  const accDiff = meanAbsDiff(first, later);
  check(accDiff > 0.05, `the picture changes as photons accumulate (frames ${f0} → ${(await viewer()).lastFrame}, mean |Δ| ${accDiff.toFixed(3)} grey levels)`);
  check((await viewer()).status.photonsPerSet > 0, 'stored photons per set are reported');
  // The progressive estimator (the default): still frames are converging passes, and the page
  // says how many.
  await waitFor('a converging frame', async () => (await viewer()).modes.some((m) => m.mode === 'converging'));
  const progress = await page.$eval('#progress', (e) => e.textContent);
  check(/estimator progressive: \d+ pass/.test(progress), `the estimator's progress is shown ("${progress}")`);
  // The status line at its longest (with the error estimate) wraps inside the page: nothing runs
  // past the 1200 px window, where it was cut off mid-sentence.
  await waitFor('the error estimate', async () => /estimated caustic error/.test(await page.$eval('#progress', (e) => e.textContent)));
  const fit = await page.evaluate(() => ({ page: document.documentElement.scrollWidth, window: window.innerWidth,
    progress: Math.ceil(document.getElementById('progress').getBoundingClientRect().right) }));
  check(fit.page <= fit.window && fit.progress <= fit.window,
    `the page fits the window's width (page ${fit.page} px, status line ends at ${fit.progress} px, window ${fit.window} px)`);

  // Before any control the page has shown no error. The screenshot README shows is taken here,
  // while the view converges: the viewer as a user first sees it.
  const banner = await page.$eval('#error', (e) => (e.hidden ? '' : e.textContent));
  const earlyErrors = (await viewer()).errors;
  check(banner === '' && earlyErrors.length === 0,
    `no error shown before any control${earlyErrors.length ? ` ("${earlyErrors.join(' | ')}")` : ''}`);
  if (args.screenshot) {
    await page.screenshot({ path: args.screenshot });
    console.log(`screenshot: ${args.screenshot}`);
  }

  // Camera: drag across the image → camera edits → a walkthrough frame and a different picture.
  const box = await (await page.$('#frame-canvas')).boundingBox();
  const before = await pixels();
  const frameBeforeDrag = (await viewer()).lastFrame;
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  for (let i = 1; i <= 10; i++) {
    await page.mouse.move(box.x + box.width / 2 + 12 * i, box.y + box.height / 2 + 2 * i);
    await sleep(40);
  }
  await page.mouse.up();
  const frameAtMouseUp = (await viewer()).status.frame;
  await waitFor('a walkthrough frame after the drag',
    async () => (await viewer()).modes.some((m) => m.frame > frameBeforeDrag && m.mode === 'walkthrough'));
  check(true, 'dragging the camera switches the mode to walkthrough');
  // Compare with a frame drawn after the camera came to rest (not a walkthrough frame, so its
  // camera is the last one) in which every set arrived: a frame shown at its deadline keeps the
  // previous values of the late sets, i.e. the old view, and on a loaded machine walkthrough
  // frames can be late.
  const settled = await waitFor('a complete frame drawn after the camera came to rest', async () => {
    const v = await viewer();
    return v.lastFrame > frameAtMouseUp &&
      v.modes.find((m) => m.frame === v.lastFrame && m.mode !== 'walkthrough' && m.complete) ? v.lastFrame : null;
  });
  const afterDrag = await pixels();
  const dragDiff = meanAbsDiff(before, afterDrag);
  check(dragDiff > 2, `the picture follows the camera (frames ${frameBeforeDrag} → ${settled}, mean |Δ| ${dragDiff.toFixed(2)} grey levels)`);

  // Light: drag the x slider → a scene edit → a new epoch at every client, begun by an Edit frame.
  const epochBefore = (await viewer()).status.epoch;
  await page.evaluate(() => {
    const r = document.getElementById('light-x');
    r.value = String(Number(r.value) + 0.1 * (Number(r.max) - Number(r.min)));
    r.dispatchEvent(new Event('input'));
  });
  const epochAfter = await waitFor('a new epoch after moving the light', async () => {
    const v = await viewer();
    return v.status.epoch > epochBefore ? v.epochs.find((e) => e.epoch > epochBefore) : null;
  });
  check(epochAfter.mode === 'edit', `moving the light resets the epoch with an edit frame (epoch ${epochBefore} → ${epochAfter.epoch}, frame ${epochAfter.frame} is ${epochAfter.mode})`);

  // Malformed controls: refused with an error in the page, nothing changes.
  const epochNow = (await viewer()).status.epoch;
  const errorsBefore = (await viewer()).errors.length;
  await page.evaluate(() => {
    rtpmViewer.ws.send('{"type":"light","index":0,"position":[1,"x",3]}');
    rtpmViewer.ws.send('{"type":"camera","yfov":1e999}');
    rtpmViewer.ws.send('{"type":"settings","M":0}');
    rtpmViewer.ws.send('not json');
  });
  await waitFor('four errors', async () => (await viewer()).errors.length >= errorsBefore + 4, 30000);
  const shown = await page.$eval('#error', (e) => !e.hidden && e.textContent);
  check(Boolean(shown) && /refused/.test(shown), `a malformed control shows an error in the page ("${shown}")`);
  const lastFrameNow = (await viewer()).lastFrame;
  await waitFor('two frames after the refused controls', async () => (await viewer()).lastFrame >= lastFrameNow + 2);
  check((await viewer()).status.epoch === epochNow, 'refused controls change nothing (same epoch)');

  // Estimator: knn from the settings form → new Settings at a new epoch, and still frames
  // accumulate (re-traced, the paper's frames) instead of converging.
  const epochBeforeKnn = (await viewer()).status.epoch;
  await page.select('#set-estimator', 'knn');
  await page.click('#settings-apply');
  const knnFrom = await waitFor('the knn estimator at a new epoch', async () => {
    const v = await viewer();
    return v.status.estimator === 'knn' && v.status.epoch > epochBeforeKnn ? v.status.frame : null;
  });
  await waitFor('an accumulating frame with knn',
    async () => (await viewer()).modes.some((m) => m.frame > knnFrom && m.mode === 'accumulate'));
  const knnModes = (await viewer()).modes.filter((m) => m.frame > knnFrom).map((m) => m.mode);
  check(!knnModes.includes('converging') && /estimator knn/.test(await page.$eval('#progress', (e) => e.textContent)),
    `the estimator switches to knn from the page (epoch ${epochBeforeKnn} → ${(await viewer()).status.epoch}, then ${[...new Set(knnModes)].join(', ')} frames)`);

  // Latest frame wins. A second page opened in front hides this one, and a hidden page holds the
  // acknowledgement of the frame it drew, as a stalled page would: it must be sent nothing more
  // while the second page keeps drawing. Brought back to the front it acknowledges, and the next
  // frame it gets is at least the newest the second page drew: never the frames it missed. (How
  // far behind the newest frame a page is depends on how fast this machine lets Chromium draw:
  // tests/bench/viewer_cost.sh measures it; here it is only printed.)
  const other = await browser.newPage();
  other.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(`second page: ${m.text()}`); });
  other.on('pageerror', (e) => consoleErrors.push(`second page: ${e}`));
  await other.goto(`${url}#token=${token}`);  // same display settings: both are sent the same encoded frames
  const otherViewer = () => other.evaluate(() => ({ framesDrawn: rtpmViewer.framesDrawn, lastFrame: rtpmViewer.lastFrame }));
  await waitFor('this page hidden behind the second, holding its acknowledgement',
    () => page.evaluate(() => document.hidden && rtpmViewer.heldAck !== null));
  const stalled = await viewer();
  await waitFor('the second page drawing three frames', async () => (await otherViewer()).framesDrawn >= 3);
  const whileStalled = await viewer();
  check(whileStalled.framesDrawn === stalled.framesDrawn,
    `a hidden page is sent no frame (drew ${whileStalled.framesDrawn - stalled.framesDrawn} while holding its acknowledgement)`);
  const newestElsewhere = (await otherViewer()).lastFrame;
  check(newestElsewhere > stalled.lastFrame,
    `a stalled page holds up no other page (second page at frame ${newestElsewhere}, stalled page at ${stalled.lastFrame})`);
  await page.bringToFront();
  await waitFor('a frame after the page came back', async () => (await viewer()).framesDrawn > stalled.framesDrawn);
  const resumed = (await viewer()).lastFrame;
  check(resumed >= newestElsewhere,
    `back in front, the page gets the newest frame, not the ones it missed (frame ${stalled.lastFrame} → ${resumed}, newest drawn by the second page ${newestElsewhere})`);
  await other.close();
  const lag = (await viewer()).lag;
  console.log(`info page lag behind the newest frame: mean ${(lag.sum / Math.max(1, lag.n)).toFixed(2)}, max ${lag.max} over ${lag.n} frames`);

  check(consoleErrors.length === 0, `no console error${consoleErrors.length ? ': ' + consoleErrors.join(' | ') : ''}`);
  await browser.close();
  browser = null;

  // Service stop: SIGTERM finishes the frame in flight, writes EXR + PNG, says Bye.
  server.kill('SIGTERM');
  const end = await Promise.race([server.exited, sleep(60000).then(() => null)]);
  check(end && end.code === 0, `SIGTERM stops the service with status 0 (${JSON.stringify(end)})`);
  check(existsSync(path.join(args.work, 'ring.exr')) && existsSync(path.join(args.work, 'ring.png')),
    'the last image was written as EXR and PNG');
  const report = /viewer: \d+ frames.*/.exec(server.out);
  check(Boolean(report), 'the server reports the viewer\'s figures');
  if (report) {
    console.log(report[0]);
    check(/(\d+) drawn by pages; lag behind the newest frame mean [0-9.]+ max \d+ frames/.test(report[0]) &&
      Number(/(\d+) drawn by pages/.exec(report[0])[1]) > 0, 'the server counts the frames pages drew and their lag');
  }
} catch (e) {
  failures.push(String(e && e.stack || e));
  console.error(e);
  if (server) console.error(server.out, server.err);
} finally {
  if (browser) await browser.close().catch(() => {});
  for (const c of children) if (c.exitCode === null && c.signalCode === null) c.kill('SIGKILL');
  await Promise.all(children.map((c) => Promise.race([c.exited, sleep(5000)])));
}
if (failures.length) {
  console.error(`viewer_test: ${failures.length} failure(s)`);
  process.exit(1);
}
console.log('viewer_test: all checks passed');
