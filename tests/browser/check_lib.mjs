// What the browser checks share: arguments, running the imuqual command and
// sqlite3, collecting failures, Chromium with a page that reports console
// errors and requests outside the server, a self-signed certificate for
// 127.0.0.1, and `imuqual serve` started on a free loopback port.
import { execFileSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { chromium } from 'playwright-core';

// --imuqual BIN [--chromium PATH]
export function parseArgs(argv) {
  const args = { chromium: '/usr/bin/chromium' };
  for (let i = 0; i < argv.length; i += 2) {
    const key = argv[i].replace(/^--/, '');
    if (!['imuqual', 'chromium'].includes(key) || i + 1 >= argv.length) {
      throw new Error(`unknown or incomplete argument '${argv[i]}'`);
    }
    args[key] = argv[i + 1];
  }
  if (!args.imuqual) throw new Error('--imuqual BIN is required');
  return args;
}

export function run(file, args) {
  try {
    return execFileSync(file, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] });
  } catch (e) {
    throw new Error(`${path.basename(file)} ${args.join(' ')} failed (exit ${e.status}): ` +
                    `${(e.stderr || '').trim()}`);
  }
}

export function sqlText(s) { return `'${s.replace(/'/g, "''")}'`; }
export function sqlite(db, sql) {
  const out = run('sqlite3', ['-json', '-bail', '-readonly', db, sql]).trim();
  return out === '' ? [] : JSON.parse(out);
}

export const failures = [];
export function fail(message) { failures.push(message); }

// Prints the failures (exit 1) or the success line; `work` is kept on failure.
export function finish(name, okLine, work, removeWork) {
  if (failures.length > 0) {
    for (const f of failures) console.error(`${name}: FAIL: ${f}`);
    console.error(`${name}: ${failures.length} failure(s); the files are kept in ${work}`);
    process.exit(1);
  }
  console.log(`${name}: OK: ${okLine}`);
  removeWork();
}

// Headless Chromium with a profile under `work`. It accepts the test's
// self-signed certificate (ignoreHTTPSErrors), and so does context.request.
export function launch(args, work) {
  return chromium.launchPersistentContext(path.join(work, 'profile'), {
    executablePath: args.chromium,
    headless: true,
    ignoreHTTPSErrors: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
           '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    timeout: 60000,
  });
}

// A self-signed certificate for 127.0.0.1 (P-256, two days) and its key
// (owner-only, as serve wants it), made by the openssl command in `work`.
export function makeCertificate(work) {
  const cert = path.join(work, 'cert.pem');
  const key = path.join(work, 'key.pem');
  run('openssl', ['req', '-x509', '-newkey', 'ec', '-pkeyopt', 'ec_paramgen_curve:P-256', '-nodes',
                  '-days', '2', '-subj', '/CN=127.0.0.1', '-addext', 'subjectAltName=IP:127.0.0.1',
                  '-keyout', key, '-out', cert]);
  fs.chmodSync(key, 0o600);
  return { cert, key };
}

// A station's keys made by `imuqual keygen` in `work` (README, "Trust"):
// { station, trust, runArgs }. runArgs: the flags that give `imuqual run`
// the station key, the roles' public keys and each role its signing key; a
// live page needs only `--trust` (it takes what the roles signed).
export function makeStationKeys(imuqual, work) {
  const dir = path.join(work, 'keys');
  fs.mkdirSync(dir, { mode: 0o700 });
  const station = path.join(dir, 'station.key');
  run(imuqual, ['keygen', '--out', station]);
  const runArgs = ['--key-file', station];
  let trust = '';
  for (const role of ['acquire', 'analyze', 'store']) {
    const key = path.join(dir, `${role}.key`);
    run(imuqual, ['keygen', '--role', role, '--out', key]);
    trust += fs.readFileSync(`${key}.pub`, 'utf8');
    runArgs.push('--sign-key', `${role}=${key}`);
  }
  const trustFile = path.join(dir, 'station.trust');
  fs.writeFileSync(trustFile, trust);
  runArgs.push('--trust', trustFile);
  return { station, trust: trustFile, runArgs };
}

// The context's page (a new one when `fresh`), failing on console errors and
// warnings, page errors and any request outside `origin` (or data: URLs).
export async function watchedPage(context, origin, { fresh = false } = {}) {
  const page = (!fresh && context.pages()[0]) || await context.newPage();
  page.on('console', (msg) => {
    if (msg.type() === 'error' || msg.type() === 'warning') fail(`console ${msg.type()}: ${msg.text()}`);
  });
  page.on('pageerror', (err) => fail(`page error: ${err.message}`));
  page.on('request', (req) => {
    const u = req.url();
    if (origin && !u.startsWith(origin + '/') && !u.startsWith('data:')) fail(`request outside the server: ${u}`);
  });
  return page;
}

// Starts `imuqual serve --listen 127.0.0.1:0 EXTRA...`; resolves to
// { child, url } once it prints a line matching `pattern` (its group 1).
export function serve(imuqual, extra, pattern = /at (https?:\/\/127\.0\.0\.1:\d+\/)/) {
  const child = spawn(imuqual, ['serve', ...extra, '--listen', '127.0.0.1:0'],
                      { stdio: ['ignore', 'pipe', 'pipe'] });
  return new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => reject(new Error(`serve printed no URL: ${out}`)), 20000);
    child.stdout.on('data', (d) => {
      out += d;
      const m = pattern.exec(out);
      if (m) {
        clearTimeout(timer);
        resolve({ child, url: m[1] });
      }
    });
    child.on('exit', (code) => reject(new Error(`serve exited ${code}: ${out}`)));
  });
}

// Resolves true when `predicate` (run in the page with `arg`) holds; false,
// with a failure, after `seconds`.
export async function waitFor(page, what, seconds, predicate, arg) {
  const deadline = Date.now() + seconds * 1000;
  for (;;) {
    if (await page.evaluate(predicate, arg)) return true;
    if (Date.now() > deadline) {
      fail(`${what}: not seen within ${seconds} s`);
      return false;
    }
    await new Promise((r) => setTimeout(r, 200));
  }
}

// The p-quantile (0..1) of `values`, nearest rank; NaN when empty.
export function percentile(values, p) {
  if (values.length === 0) return NaN;
  const sorted = [...values].sort((a, b) => a - b);
  return sorted[Math.min(sorted.length - 1, Math.max(0, Math.ceil(p * sorted.length) - 1))];
}

// The screen a person first sees: the page at 1400x1000 (or `size`), scrolled to the top,
// saved as NAME.png (in IMUQUAL_SCREENS, else ./screens under the test's
// working directory) and checked: no text overflows its box (the page wider
// than the screen; a box that clips or scrolls its text; text running past
// the right edge of its own box; a plot label outside its plot or over
// another label), and each element that `first` names ({ what, selector }) is
// inside the first screen. Each problem is one failure naming the page.
export async function screenCheck(page, name, first = [], size = { width: 1400, height: 1000 }) {
  await page.setViewportSize(size);
  await page.evaluate(() => window.scrollTo(0, 0));
  const dir = process.env.IMUQUAL_SCREENS || path.join(process.cwd(), 'screens');
  fs.mkdirSync(dir, { recursive: true });
  await page.screenshot({ path: path.join(dir, `${name}.png`) });
  const problems = await page.evaluate((firstOnes) => {
    const out = [];
    const clip = (s) => (s.length > 40 ? `${s.slice(0, 40)}...` : s);
    const label = (el) => `<${el.tagName.toLowerCase()}${el.id ? `#${el.id}` : ''}` +
        `${typeof el.className === 'string' && el.className ? `.${el.className.split(/\s+/).join('.')}` : ''}>`;
    const visible = (el) => {
      const r = el.getBoundingClientRect();
      return r.width > 0 && r.height > 0 && getComputedStyle(el).visibility !== 'hidden';
    };
    const doc = document.documentElement;
    if (doc.scrollWidth > window.innerWidth + 1) {
      out.push(`the page is ${doc.scrollWidth} px wide, wider than the screen`);
    }
    for (const el of document.body.querySelectorAll('*')) {
      if (el.closest('svg') || !visible(el)) continue;
      const text = [...el.childNodes].filter((n) => n.nodeType === Node.TEXT_NODE)
          .map((n) => n.textContent).join('').trim();
      const cs = getComputedStyle(el);
      if (cs.overflowX !== 'visible' && el.scrollWidth > el.clientWidth + 1 && el.textContent.trim()) {
        out.push(`${label(el)} hides ${el.scrollWidth - el.clientWidth} px of its content ` +
                 `('${clip(el.textContent.trim())}')`);
      }
      if (!text) continue;
      const range = document.createRange();
      range.selectNodeContents(el);
      const box = el.getBoundingClientRect();
      for (const r of range.getClientRects()) {
        if (r.width > 0 && r.right > box.right + 1 && cs.display !== 'inline') {
          out.push(`text of ${label(el)} runs ${Math.round(r.right - box.right)} px past its box ('${clip(text)}')`);
          break;
        }
      }
    }
    for (const svg of document.querySelectorAll('svg')) {
      if (!visible(svg)) continue;
      const frame = svg.getBoundingClientRect();
      const texts = [...svg.querySelectorAll('text')].filter((t) => t.textContent.trim())
          .map((t) => ({ t: t.textContent.trim(), r: t.getBoundingClientRect() }));
      for (const { t, r } of texts) {
        if (r.left < frame.left - 1 || r.right > frame.right + 1 || r.top < frame.top - 1 ||
            r.bottom > frame.bottom + 1) {
          out.push(`plot label '${clip(t)}' lies outside its plot`);
        }
      }
      for (let i = 0; i < texts.length; ++i) {
        for (let j = i + 1; j < texts.length; ++j) {
          const a = texts[i].r, b = texts[j].r;
          const w = Math.min(a.right, b.right) - Math.max(a.left, b.left);
          const h = Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top);
          if (w > 1 && h > 1 && w * h > 4) {
            out.push(`plot labels '${clip(texts[i].t)}' and '${clip(texts[j].t)}' overlap`);
          }
        }
      }
    }
    for (const { what, selector } of firstOnes) {
      const el = document.querySelector(selector);
      if (!el) {
        out.push(`no ${what} (${selector})`);
        continue;
      }
      const r = el.getBoundingClientRect();
      if (r.top < 0 || r.bottom > window.innerHeight) {
        out.push(`${what} is at ${Math.round(r.top)}-${Math.round(r.bottom)} px, outside the first screen (0-${window.innerHeight})`);
      }
    }
    return out;
  }, first);
  for (const p of problems) fail(`${name} page at ${size.width}x${size.height}: ${p}`);
}
