// The live station page of `imuqual serve --bus` in a real browser, during
// a real soak.
//
// GIVEN `imuqual serve --db DB --bus URL` over TLS with a token (a
//       self-signed certificate made here) started before the station (the
//       archive does not exist yet), and `imuqual run` soaking 4 simulated
//       VG700-like gyros on that bus, paced so that the soak lasts about a
//       minute, with an operator name that is hostile HTML,
// WHEN  headless Chromium opens /live?token=... once (the cookie carries the
//       event stream and every page after it) and watches the soak; halfway the
//       station's store process is killed (the station restarts it),
// THEN  a row appears for every unit and its samples grow; each unit's Allan
//       curves are drawn and grow, every plot on the lot's one y range with
//       the plan's bias-instability limits and a coloured legend; the killed store is shown restarted
//       ("store up (restarted 1x)"); at the end every unit shows its final
//       verdict, equal to the archive's (sqlite3), the tally is shown, and
//       the report link leads to the lot's report; the hostile operator
//       name shows as text and runs nothing; no console error, no page
//       error, no request to anything but the server. The page's update
//       latency (result published -> shown) is printed, not asserted.
//
// Usage: node live_check.mjs --imuqual BIN [--chromium PATH]
import { execFileSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import {
  fail, finish, launch, makeCertificate, makeStationKeys, parseArgs, percentile, screenCheck, serve, sqlite,
  waitFor,
  watchedPage,
} from './check_lib.mjs';

const kLot = 'LIVE';
const kUnits = 4;
const kDurationS = 3660;  // the plan's warm-up + minimum: judged, not too short
const kPace = 60;         // about a minute of wall time
const kOperator = 'op"><img src=x onerror="window.injected=3">';

async function main() {
  const args = parseArgs(process.argv.slice(2));
  const started = Date.now();
  const work = fs.mkdtempSync(path.join(os.tmpdir(), 'imuqual-live-'));
  const db = path.join(work, 'live.db');
  const bus = `udpm://239.255.76.67:${20000 + (process.pid % 30000)}?ttl=0`;
  const { cert, key } = makeCertificate(work);
  // A keyed station; the page's server holds only the roles' public keys.
  const keys = makeStationKeys(args.imuqual, work);
  const tokenFile = path.join(work, 'token');
  fs.writeFileSync(tokenFile, 'live-check-token-0123456789\n', { mode: 0o600 });
  const { child: server, url: live } = await serve(
    args.imuqual, ['--db', db, '--bus', bus, '--trust', keys.trust, '--tls-cert', cert, '--tls-key', key,
                   '--token-file', tokenFile],
    /live station \(bus [^)]*\): (https:\/\/127\.0\.0\.1:\d+\/live)/);
  const origin = new URL(live).origin;
  const context = await launch(args, work);
  let station = null;
  let stationLog = '';
  try {
    const page = await watchedPage(context, origin);
    const response = await page.goto(`${live}?token=live-check-token-0123456789`,
                                      { waitUntil: 'load', timeout: 30000 });
    if (!response || response.status() !== 200) fail(`${live}: status ${response?.status()}`);
    await waitFor(page, 'the page connected', 20, () => window.imuqualLive?.updates > 0);

    station = spawn(args.imuqual, ['run', '--sim', String(kUnits), '--duration', String(kDurationS),
                                   '--lot', kLot, '--db', db, '--lcm-url', bus, '--pace', String(kPace),
                                   '--operator', kOperator, '--quiet', ...keys.runArgs],
                    { stdio: ['ignore', 'pipe', 'pipe'] });
    station.stdout.on('data', (d) => { stationLog += d; });
    station.stderr.on('data', (d) => { stationLog += d; });
    const stationDone = new Promise((resolve) => station.on('exit', (code) => resolve(code)));

    // Rows appear, one per unit, and their samples grow.
    await waitFor(page, `${kUnits} unit rows`, 40, (n) =>
      document.querySelectorAll('#units tbody tr.first').length === n, kUnits);
    const samplesOf = () => page.evaluate(() => Object.fromEntries(
      [...document.querySelectorAll('#units tbody tr.first')].map((tr) => [tr.dataset.serial, Number(tr.cells[9].textContent)])));
    const first = await samplesOf();
    await page.waitForTimeout(3000);
    const later = await samplesOf();
    for (const [serial, n] of Object.entries(first)) {
      if (!(later[serial] > n)) fail(`unit ${serial}: samples did not grow (${n} -> ${later[serial]})`);
    }
    // Progress from each run's announced planned length (the page knows no
    // station duration): above 0 and rising, each unit "elapsed / planned",
    // and the bar what the units' own elapsed/planned say (the console's rule).
    const progress = () => page.evaluate(() => Number(document.getElementById('progress').value));
    const p1 = await progress();
    await page.waitForTimeout(3000);
    const p2 = await progress();
    if (!(p1 > 0 && p2 > p1)) fail(`progress did not rise from 0: ${p1} -> ${p2}`);
    const fromUnits = await page.evaluate(() => {
      const units = window.imuqualLive.status.units;
      return units.reduce((sum, u) => sum + (u.archived ? 1 : Math.min(u.elapsed_s / u.planned_s, 0.999)), 0) / units.length;
    });
    const p3 = await progress();
    if (!(Math.abs(p3 - fromUnits) <= 0.05)) fail(`progress ${p3}, the units' elapsed/planned say ${fromUnits}`);
    // Each axis's invalid samples, in its own column as the status says (0 for simulated units).
    const invalid = await page.evaluate(() => {
      const head = [...document.querySelectorAll('#units thead th')].map((th) => th.textContent);
      const at = head.indexOf('invalid');
      const shown = [...document.querySelectorAll('#units tbody tr')].map((tr) => tr.cells[at]?.textContent);
      const said = window.imuqualLive.status.units.flatMap((u) => u.axes.map((x) => x.invalid_samples));
      return { at, shown, said };
    });
    if (invalid.at < 0) fail('the unit table has no "invalid" column');
    if (!invalid.said.every((n) => n === 0)) fail(`invalid samples of simulated units: ${invalid.said}`);
    if (!invalid.shown.every((t) => t === '0')) fail(`invalid column shows ${invalid.shown}`);
    const planned = await page.evaluate(() => window.imuqualLive.status.units.map((u) => u.planned_s));
    if (!planned.every((p) => Math.abs(p - kDurationS) < 1e-6)) fail(`planned lengths ${planned}, ${kDurationS} s soaked`);
    const operator = await page.evaluate(() => document.getElementById('operator').textContent);
    if (operator !== kOperator) fail(`operator shown as '${operator}'`);
    // Curves drawn for every unit, and they grow (more samples behind them).
    await waitFor(page, 'a curve for every unit', 40, (n) =>
      [...document.querySelectorAll('#curves figure')].filter((f) => f.querySelector('polyline')).length === n, kUnits);
    const curveSamples = () => page.evaluate(() => [...document.querySelectorAll('#curves polyline title')]
      .map((t) => Number(/(\d+) samples/.exec(t.textContent)?.[1] || 0)).reduce((a, b) => a + b, 0));
    const before = await curveSamples();
    await page.waitForTimeout(4000);
    if (!(await curveSamples() > before)) fail('the curves did not grow');
    // Every plot on one y range (the lot's), the plan's limits on the curve
    // minimum drawn where the status carries them, and a coloured legend: a
    // swatch per curve, its name in the curve's colour.
    const tiles = await page.evaluate(() => [...document.querySelectorAll('#curves figure')].map((f) => ({
      yTicks: [...f.querySelectorAll('svg text[text-anchor="end"]')].filter((t) => t.getAttribute('x') === '47')
        .map((t) => t.textContent).join(' '),
      limits: [...f.querySelectorAll('line.limit')].map((l) => Number(l.dataset.value)).sort((a, b) => a - b),
      curves: [...f.querySelectorAll('polyline')].map((p) => p.getAttribute('stroke')),
      swatches: [...f.querySelectorAll('line.swatch')].map((l) => l.getAttribute('stroke')),
      // The legend's names: the texts right after each swatch.
      keyColours: [...f.querySelectorAll('line.swatch')].map((l) => getComputedStyle(l.nextElementSibling).fill),
    })));
    const wantLimits = await page.evaluate(() => [...new Set(window.imuqualLive.status.units.flatMap((u) => u.axes)
      .flatMap((x) => [x.limit_high, x.marginal_high]).filter((v) => v > 0))].sort((a, b) => a - b));
    if (wantLimits.length === 0) fail('the status carries no plan limit on bias_instability (vg700ca has 20 and 16 deg/h)');
    for (const t of tiles) {
      if (t.yTicks !== tiles[0].yTicks) fail(`plots on different y ranges: '${t.yTicks}' and '${tiles[0].yTicks}'`);
      if (JSON.stringify(t.limits) !== JSON.stringify(wantLimits)) fail(`limit lines ${t.limits}, the plan's ${wantLimits}`);
      if (JSON.stringify(t.swatches) !== JSON.stringify(t.curves)) fail(`legend swatches ${t.swatches} for curves ${t.curves}`);
      const rgb = (hex) => `rgb(${parseInt(hex.slice(1, 3), 16)}, ${parseInt(hex.slice(3, 5), 16)}, ${parseInt(hex.slice(5, 7), 16)})`;
      if (JSON.stringify(t.keyColours) !== JSON.stringify(t.swatches.map(rgb))) {
        fail(`legend names in ${t.keyColours}, their curves in ${t.swatches}`);
      }
    }

    // The screen mid-soak: nothing cut, the worst unit's row and tile in view.
    await screenCheck(page, 'live-soak', [{ what: 'the first unit row', selector: '#units tbody tr.first' }]);
    // On a 1920x1080 wall screen the table and every unit's plot are in view.
    await screenCheck(page, 'live-wall', [{ what: 'the first unit row', selector: '#units tbody tr.first' },
                                          { what: 'the last unit\'s plot', selector: '#curves figure:last-of-type' }],
                      { width: 1920, height: 1080 });

    // The store killed: the station restarts it, the page says so.
    const storePid = Number(execFileSync('pgrep', ['-P', String(station.pid), '-x', 'imuqual-store'],
                                         { encoding: 'utf8' }).trim().split('\n')[0]);
    if (!(storePid > 0)) {
      fail('no imuqual-store child of the station found');
    } else {
      process.kill(storePid, 'SIGKILL');
      if (!await waitFor(page, 'the killed store shown restarted', 30, () =>
        /store up \(restarted 1x\)/.test(document.getElementById('processes').textContent))) {
        fail(`processes shown: '${await page.evaluate(() => document.getElementById('processes').textContent)}'`);
      }
    }

    // The end: final verdicts equal to the archive's, the tally, the report link.
    const code = await stationDone;
    if (code !== 0) fail(`imuqual run exited ${code}: ${stationLog.slice(-2000)}`);
    await waitFor(page, 'every unit final and archived (report link shown)', 60, () =>
      !document.getElementById('done').hidden);
    const shown = await page.evaluate(() => [...document.querySelectorAll('#units tbody tr.first')]
      .map((tr) => ({ serial: tr.dataset.serial, verdict: tr.cells[2].textContent, state: tr.cells[4].textContent })));
    // FAIL, INCONCLUSIVE and MARGINAL units first (the line acts on them).
    const rank = { FAIL: 5, ERROR: 4, ABORTED: 3, INCONCLUSIVE: 2, MARGINAL: 1 };
    const ranks = shown.map((r) => rank[r.verdict] || 0);
    if (ranks.some((r, i) => i > 0 && r > ranks[i - 1])) {
      fail(`rows not worst first: ${shown.map((r) => `${r.serial} ${r.verdict}`).join(', ')}`);
    }
    const archived = sqlite(db, `SELECT serial, verdict FROM runs WHERE lot = '${kLot}' ORDER BY serial`);
    if (archived.length !== kUnits) fail(`${archived.length} runs archived, ${kUnits} expected`);
    for (const a of archived) {
      const row = shown.find((s) => s.serial === a.serial);
      if (!row) { fail(`unit ${a.serial} not shown at the end`); continue; }
      if (row.verdict !== a.verdict) fail(`unit ${a.serial}: page verdict '${row.verdict}', archive '${a.verdict}'`);
      if (row.state !== 'done') fail(`unit ${a.serial}: state '${row.state}' at the end`);
    }
    const tally = await page.evaluate(() => document.getElementById('tally').textContent);
    if (!/^final: /.test(tally)) fail(`no tally at the end: '${tally}'`);
    const worst = shown.find((r) => r.verdict === 'FAIL') ?? shown[0];
    await screenCheck(page, 'live', [
      { what: `the first unit row (${worst.serial} ${worst.verdict})`, selector: '#units tbody tr.first' },
      { what: 'the tally', selector: '#tally' }]);
    const report = await page.evaluate(() => document.getElementById('report').getAttribute('href'));
    if (report !== `/lot/${kLot}`) fail(`report link '${report}'`);
    if (await page.evaluate(() => window.injected !== undefined)) fail('a hostile string ran on the live page');
    const latencies = await page.evaluate(() => window.imuqualLive?.latencies_ms || []);
    console.log(`live_check: update latency over ${latencies.length} updates: p50 ` +
                `${percentile(latencies, 0.5).toFixed(0)} ms, p99 ${percentile(latencies, 0.99).toFixed(0)} ms`);
    const lotPage = await page.goto(new URL(report, origin).href, { waitUntil: 'load' });
    if (lotPage?.status() !== 200 || !(await page.title()).startsWith(`Lot ${kLot}`)) {
      fail(`the report link did not lead to the lot's report (${lotPage?.status()})`);
    }
  } finally {
    await context.close();
    if (station && station.exitCode === null) station.kill('SIGINT');
    server.kill('SIGTERM');
  }
  const seconds = ((Date.now() - started) / 1000).toFixed(1);
  finish('live_check', `over TLS with a token: ${kUnits} units appeared and grew, curves drawn, the killed store shown ` +
         `restarted, final verdicts equal to the archive's, report link (${seconds} s)`,
         work, () => fs.rmSync(work, { recursive: true, force: true }));
}

main().catch((e) => {
  console.error(`live_check: FAIL: ${e.message}`);
  process.exit(1);
});
