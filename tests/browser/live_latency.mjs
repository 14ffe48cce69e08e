// Benchmark (scripts/bench web): how long the live station page takes to
// show what the station just did. `imuqual serve --bus` listens to a paced
// soak of UNITS simulated VG700-like gyros (2 analyze shards); headless
// Chromium keeps /live open to the end. For every update that carries a
// newer result or acknowledgement, the page records the time from its
// publication on the bus (the analysis's or the store's clock, this host)
// to the frame after it was drawn (window.imuqualLive.latencies_ms).
// Prints "name value unit" lines; never fails on a figure.
//
// Usage: node live_latency.mjs --imuqual BIN [--chromium PATH]   (UNITS=16 PACE=60)
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import {
  failures, launch, makeStationKeys, parseArgs, percentile, serve, waitFor, watchedPage,
} from './check_lib.mjs';

const kUnits = Number(process.env.UNITS || 16);
const kPace = Number(process.env.PACE || 60);
const kDurationS = 3660;

async function main() {
  const args = parseArgs(process.argv.slice(2));
  const work = fs.mkdtempSync(path.join(os.tmpdir(), 'imuqual-live-bench-'));
  const db = path.join(work, 'bench.db');
  const bus = `udpm://239.255.76.67:${20000 + (process.pid % 30000)}?ttl=0`;
  const keys = makeStationKeys(args.imuqual, work);  // a keyed station, the page with its public keys
  const { child: server, url: live } = await serve(args.imuqual, ['--db', db, '--bus', bus, '--trust', keys.trust],
                                                   /live station \(bus [^)]*\): (http:\/\/127\.0\.0\.1:\d+\/live)/);
  const context = await launch(args, work);
  try {
    const page = await watchedPage(context, new URL(live).origin);
    await page.goto(live, { waitUntil: 'load' });
    await waitFor(page, 'the page connected', 20, () => window.imuqualLive?.updates > 0);
    const station = spawn(args.imuqual, ['run', '--sim', String(kUnits), '--duration', String(kDurationS),
                                         '--lot', 'BENCH', '--db', db, '--lcm-url', bus, '--pace', String(kPace),
                                         '--analyze-shards', '2', '--quiet', ...keys.runArgs],
                          { stdio: 'ignore' });
    const code = await new Promise((resolve) => station.on('exit', resolve));
    if (code !== 0) throw new Error(`imuqual run exited ${code}`);
    await waitFor(page, 'the end of the soak', 60, () => !document.getElementById('done').hidden);
    const live_ = await page.evaluate(() => ({ l: window.imuqualLive.latencies_ms, u: window.imuqualLive.updates }));
    const l = live_.l;
    console.log(`live_units ${kUnits} units`);
    console.log(`live_updates ${live_.u} updates`);
    console.log(`live_update_latency_p50_ms ${percentile(l, 0.5).toFixed(0)} ms`);
    console.log(`live_update_latency_p99_ms ${percentile(l, 0.99).toFixed(0)} ms`);
    console.log(`live_update_latency_max_ms ${Math.max(...l).toFixed(0)} ms`);
    if (failures.length > 0) console.error(`live_latency: ${failures.join('; ')}`);
  } finally {
    await context.close();
    server.kill('SIGTERM');
    fs.rmSync(work, { recursive: true, force: true });
  }
}

main().catch((e) => {
  console.error(`live_latency: not measurable: ${e.message}`);
  console.log('live_update_latency_p99_ms nan ms');
  process.exit(0);
});
