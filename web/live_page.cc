#include "web/live_page.h"

#include "common/text_util.h"
#include "web/pages.h"

namespace imuqual::web {
namespace {

constexpr char kLiveStyle[] = R"css(
<style>
progress { width: 320px; height: 14px; vertical-align: middle; }
#conn.lost { color: #b3261e; font-weight: 600; }
.state-alarm { color: #b3261e; font-weight: 700; }
.prov { font-style: italic; }
table.data tr.first td { border-top: 2px solid #c9d1d9; }
.cards { display: flex; flex-wrap: wrap; gap: 12px; }
.cards figure { border: 1px solid #dde2e6; border-radius: 4px; padding: 6px; margin: 0; }
.cards figcaption { font-size: 12.5px; }
.cards svg text { font-size: 10px; fill: #39424a; }
</style>
)css";

// The page's script: an EventSource on /live/events; "status" redraws the
// header and the table, "curve" one unit's plot. Text only via textContent.
constexpr char kLiveScript[] = R"js((() => {
  'use strict';
  const live = window.imuqualLive = { updates: 0, curveEvents: 0, latencies_ms: [], status: null };
  const $ = (id) => document.getElementById(id);
  const svgNS = 'http://www.w3.org/2000/svg';
  const el = (tag, text, cls) => {
    const e = document.createElement(tag);
    if (text !== undefined && text !== null) e.textContent = String(text);
    if (cls) e.className = cls;
    return e;
  };
  const sv = (tag, attrs) => {
    const e = document.createElementNS(svgNS, tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, String(v));
    return e;
  };
  const kOutcomes = ['PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE', 'ABORTED', 'ERROR'];
  // The outcome a verdict's words name ("fail?", "decided PASS at 14m"), for its colour.
  // "pending" (a provisional value that can still change side) is coloured
  // as INCONCLUSIVE.
  const outcomeOf = (text) => {
    const words = String(text || '').replace(/[?]/g, '').split(/\s+/)
        .map((w) => (w === 'pending' ? 'INCONCLUSIVE' : w.toUpperCase()));
    return kOutcomes.find((o) => words.includes(o)) || '';
  };
  const verdictCell = (text) => {
    const td = el('td', text, 'verdict ' + outcomeOf(text));
    if (/\?$|^pending/.test(text)) td.classList.add('prov');
    return td;
  };
  const duration = (s) => {
    s = Math.max(0, Math.round(s || 0));
    const pad = (n) => String(n).padStart(2, '0');
    return s >= 3600 ? `${Math.floor(s / 3600)}:${pad(Math.floor(s / 60) % 60)}:${pad(s % 60)}`
                     : `${Math.floor(s / 60)}:${pad(s % 60)}`;
  };
  // "/prefix/NAME", or "/prefix?key=NAME" for "." and ".." (a browser resolves those away).
  const nameLink = (prefix, key, name) => (name === '.' || name === '..')
    ? `${prefix}?${key}=${encodeURIComponent(name)}` : `${prefix}/${encodeURIComponent(name)}`;
  const curves = new Map();   // run id -> Map(axis -> curve)
  const figures = new Map();  // run id -> {figure, caption, svg}
  const limits = new Map();   // run id -> Map(axis -> {high, marginal}) from the plan
  let yRange = null;          // [lowest decade, highest decade]: one for every plot
  let newest = 0;

  function row(u, first, axis, nAxes) {
    const tr = el('tr', null, first ? 'first' : '');
    tr.dataset.serial = u.serial;
    if (axis) tr.dataset.axis = axis.name;
    const cell = (text) => el('td', first ? text : '');
    tr.append(cell(u.slot));
    const serial = el('td');
    if (first) {
      const a = el('a', u.serial);
      a.href = nameLink('/unit', 'serial', u.serial);
      serial.append(a);
      if (u.archived && u.run_id) {
        const r = el('a', 'run');
        r.href = nameLink('/run', 'id', u.run_id);
        r.className = 'runlink';
        serial.append(' ', r);
      }
    }
    tr.append(serial);
    tr.append(first ? verdictCell(u.verdict) : el('td'));
    tr.lastChild.classList.add('unit-verdict');
    tr.append(cell(u.reason));
    const state = cell(u.state);
    state.classList.add('state');
    if (first && /^(no data|reconnecting|source failed|aborted|incomplete)/.test(u.state)) {
      state.classList.add('state-alarm');
    }
    tr.append(state);
    tr.append(cell(u.elapsed));
    tr.append(el('td', axis ? axis.name : ''));
    tr.append(axis ? verdictCell(axis.verdict) : el('td'));
    tr.lastChild.classList.add('axis-verdict');
    tr.append(el('td', axis ? axis.bias_instability : '', 'num bi'));
    tr.append(el('td', first && u.run_id ? u.samples : '', 'num'));
    tr.append(el('td', first && u.run_id ? u.gap_samples : '', 'num'));
    const invalid = el('td', axis && u.run_id ? axis.invalid_samples : '', 'num invalid');
    if (axis && axis.invalid_samples > 0) invalid.classList.add('state-alarm');
    tr.append(invalid);
    return tr;
  }

  function renderStatus(s) {
    live.status = s;
    $('station').textContent = s.station || '(no run heard yet)';
    for (const k of ['lot', 'plan', 'operator', 'bus', 'archive']) $(k).textContent = s[k] || '';
    $('progress').value = s.progress || 0;
    const archived = s.units.filter((u) => u.archived).length;
    $('progress-text').textContent = `${Math.round(100 * (s.progress || 0))}%   elapsed ` +
        `${duration(s.wall_s)}   runs archived ${archived}/${s.units.length}`;
    $('processes').textContent = s.processes_line;
    $('tally').textContent = s.tally;
    const done = $('done');
    done.hidden = !(s.all_done && s.lot);
    if (!done.hidden) $('report').href = nameLink('/lot', 'name', s.lot);
    // What needs the line first: FAIL, ERROR (a failed source, a silent
    // unit), ABORTED, INCONCLUSIVE, MARGINAL, then the rest; slot order within.
    const units = [...s.units].sort((a, b) => (b.attention || 0) - (a.attention || 0));
    const body = document.createElement('tbody');
    for (const u of units) {
      const axes = u.axes.length ? u.axes : [null];
      axes.forEach((x, i) => body.append(row(u, i === 0, x, axes.length)));
    }
    $('units').tBodies[0].replaceWith(body);
    // The plan's limits on each axis's curve minimum, drawn on its plot.
    for (const u of units) {
      if (!u.run_id) continue;
      const m = new Map();
      for (const x of u.axes || []) m.set(x.name, { high: x.limit_high, marginal: x.marginal_high });
      limits.set(u.run_id, m);
    }
    // One plot per unit with a run, in the table's order.
    const box = $('curves');
    const order = [];
    for (const u of units) {
      if (!u.run_id) continue;
      let f = figures.get(u.run_id);
      if (!f) {
        const figure = el('figure');
        figure.dataset.run = u.run_id;
        figure.dataset.serial = u.serial;
        const caption = el('figcaption');
        const svg = sv('svg', { width: 320, height: 200, viewBox: '0 0 320 200', role: 'img' });
        figure.append(caption, svg);
        f = { figure, caption, svg };
        figures.set(u.run_id, f);
        drawAll(u.run_id);
      }
      f.caption.textContent = '';
      f.caption.append(`${u.slot} ${u.serial} `, el('span', u.verdict, 'verdict ' + outcomeOf(u.verdict)));
      order.push(f.figure);
    }
    for (const [run, f] of figures) {
      if (!order.includes(f.figure)) { figures.delete(run); curves.delete(run); limits.delete(run); }
    }
    box.replaceChildren(...order);
    live.updates++;
    if (s.newest_utime > newest) {
      newest = s.newest_utime;
      const published_ms = s.newest_utime / 1000;
      requestAnimationFrame(() => {
        live.latencies_ms.push(Date.now() - published_ms);
        if (live.latencies_ms.length > 20000) live.latencies_ms.splice(0, 10000);
      });
    }
  }

  const kColours = ['#1f6feb', '#bf8700', '#8250df', '#1a7f37', '#cf222e', '#57606a'];
  const tickText = (v) => (v >= 1e4 || v < 1e-3) ? v.toExponential(0) : String(Number(v.toPrecision(3)));

  // The deviation decades of every unit's curves and limits: one y range
  // for the lot, so that a unit's curve reads against the others'.
  function lotRange() {
    let d0 = Infinity, d1 = 0;
    const take = (d) => { if (d > 0 && Number.isFinite(d)) { d0 = Math.min(d0, d); d1 = Math.max(d1, d); } };
    // Only the runs shown (a curve event may come for a run no longer in the table).
    for (const run of figures.keys()) {
      for (const c of (curves.get(run) || new Map()).values()) c.dev.forEach(take);
      for (const l of (limits.get(run) || new Map()).values()) { take(l.high); take(l.marginal); }
    }
    if (!(d1 > 0)) return null;
    const ld0 = Math.floor(Math.log10(d0));
    return [ld0, Math.max(ld0 + 1, Math.ceil(Math.log10(d1)))];
  }
  // Draws `run`'s plot, or every plot when the lot's range changed.
  function drawAll(run) {
    const r = lotRange();
    if (r && (!yRange || r[0] !== yRange[0] || r[1] !== yRange[1])) {
      yRange = r;
      for (const other of figures.keys()) draw(other);
    } else {
      draw(run);
    }
  }

  function draw(run) {
    const f = figures.get(run);
    if (!f) return;
    const svg = f.svg;
    svg.replaceChildren();
    const byAxis = curves.get(run);
    const list = byAxis ? [...byAxis.values()] : [];
    const W = 320, H = 200, L = 50, R = 8, T = 8, B = 30;
    if (!list.length || !yRange) {
      svg.append(Object.assign(sv('text', { x: L, y: H / 2 }), { textContent: 'no curve yet' }));
      return;
    }
    let t0 = Infinity, t1 = 0;
    for (const c of list) c.tau_s.forEach((t) => { if (t > 0) { t0 = Math.min(t0, t); t1 = Math.max(t1, t); } });
    if (!(t1 > 0)) return;
    const lt0 = Math.floor(Math.log10(t0)), lt1 = Math.max(lt0 + 1, Math.ceil(Math.log10(t1)));
    const [ld0, ld1] = yRange;
    const x = (t) => L + (Math.log10(t) - lt0) / (lt1 - lt0) * (W - L - R);
    const y = (d) => T + (ld1 - Math.log10(d)) / (ld1 - ld0) * (H - T - B);
    const grid = sv('g', { stroke: '#e3e7eb', 'stroke-width': 1 });
    svg.append(grid);
    for (let k = lt0; k <= lt1; k++) {
      grid.append(sv('line', { x1: x(10 ** k), x2: x(10 ** k), y1: T, y2: H - B }));
      // The end ticks' labels stay inside the plot's width (the first clear of
      // the y labels).
      const anchor = k === lt0 ? 'start' : k === lt1 ? 'end' : 'middle';
      const label = sv('text', { x: x(10 ** k), y: H - B + 12, 'text-anchor': anchor });
      label.textContent = tickText(10 ** k);
      svg.append(label);
    }
    for (let k = ld0; k <= ld1; k++) {
      grid.append(sv('line', { x1: L, x2: W - R, y1: y(10 ** k), y2: y(10 ** k) }));
      const label = sv('text', { x: L - 3, y: y(10 ** k) + 3, 'text-anchor': 'end' });
      label.textContent = tickText(10 ** k);
      svg.append(label);
    }
    const axisLabel = sv('text', { x: (L + W - R) / 2, y: H - 3, 'text-anchor': 'middle' });
    const first = list[0];
    axisLabel.textContent = `tau, s   (${first.estimator}, ${first.unit}${list.every((c) => c.final) ? ', final' : ', interim'})`;
    svg.append(axisLabel);
    // The plan's limits on the curve minimum: the limit red, the marginal
    // bound amber, dashed, labelled (once per value: the axes of a kind share them).
    const drawn = new Set();
    for (const c of list) {
      const l = (limits.get(run) || new Map()).get(c.axis);
      if (!l) continue;
      for (const [v, colour, word] of [[l.high, '#cf222e', 'limit'], [l.marginal, '#bf8700', 'marginal']]) {
        if (!(v > 0) || drawn.has(v)) continue;
        drawn.add(v);
        const line = sv('line', { x1: L, x2: W - R, y1: y(v), y2: y(v), stroke: colour, 'stroke-width': 1.2,
                                  'stroke-dasharray': '5,3' });
        line.classList.add('limit');
        line.dataset.value = String(v);
        svg.append(line);
        // The limit's label above its line, the marginal bound's below its
        // own: the two never overlap, however close the values.
        const text = sv('text', { x: L + 3, y: word === 'limit' ? y(v) - 3 : y(v) + 10 });
        text.style.fill = colour;
        text.textContent = `${word} ${tickText(v)} ${c.unit}`;
        svg.append(text);
      }
    }
    list.forEach((c, i) => {
      const colour = kColours[i % kColours.length];
      const pts = [];
      c.tau_s.forEach((t, j) => { if (t > 0 && c.dev[j] > 0) pts.push(`${x(t).toFixed(1)},${y(c.dev[j]).toFixed(1)}`); });
      const line = sv('polyline', { points: pts.join(' '), fill: 'none', stroke: colour, 'stroke-width': 1.6 });
      line.dataset.axis = c.axis;
      const title = sv('title');
      title.textContent = `${c.axis}: ${c.estimator} in ${c.unit}, ${c.samples} samples${c.final ? ', final' : ''}`;
      line.append(title);
      svg.append(line);
      // The legend: a swatch of the axis's colour and its name (the page's
      // grey text style would hide a fill attribute: the colour is a style).
      const ky = T + 10 + 12 * i;
      const swatch = sv('line', { x1: W - R - 30, x2: W - R - 16, y1: ky - 3, y2: ky - 3, stroke: colour, 'stroke-width': 3 });
      swatch.classList.add('swatch');
      svg.append(swatch);
      const key = sv('text', { x: W - R - 4, y: ky, 'text-anchor': 'end' });
      key.style.fill = colour;
      key.textContent = c.axis;
      svg.append(key);
    });
  }

  // The event stream. The browser reconnects a dropped stream by itself; a
  // refused one (503: too many pages open, or the server restarting) is
  // closed for good, so the page opens a new one after a while.
  function connect() {
    const source = new EventSource('/live/events');
    source.addEventListener('open', () => { $('conn').textContent = 'live: listening to the station bus'; $('conn').className = 'note'; });
    source.addEventListener('error', () => {
      $('conn').className = 'lost';
      if (source.readyState === EventSource.CLOSED) {
        $('conn').textContent = 'the server refused the live stream: trying again in 10 s';
        setTimeout(connect, 10000);
      } else {
        $('conn').textContent = 'connection to the server lost: retrying';
      }
    });
    source.addEventListener('status', (e) => renderStatus(JSON.parse(e.data)));
    source.addEventListener('curve', (e) => {
      const c = JSON.parse(e.data);
      live.curveEvents++;
      if (!curves.has(c.run_id)) curves.set(c.run_id, new Map());
      curves.get(c.run_id).set(c.axis, c);
      drawAll(c.run_id);
    });
  }
  connect();
})();
)js";

}  // namespace

std::string LivePageHtml(const std::string& bus_url) {
  if (bus_url.empty()) {
    return PageHtml(
        "live station",
        "<h1>Live station</h1>\n<p>This server was started without a station bus. Start it as "
        "<code>imuqual serve --db FILE --bus URL</code> with the bus URL the station's console "
        "shows (<code>imuqual run --lcm-url URL</code> chooses it) to watch a soak here.</p>\n");
  }
  std::string body = kLiveStyle;
  body +=
      "<h1>Live station <span id=\"station\"></span></h1>\n"
      "<p id=\"conn\" class=\"note\">connecting ...</p>\n"
      "<dl><dt>lot</dt><dd id=\"lot\"></dd><dt>plan</dt><dd id=\"plan\"></dd>"
      "<dt>operator</dt><dd id=\"operator\"></dd><dt>bus</dt><dd id=\"bus\"></dd>"
      "<dt>archive</dt><dd id=\"archive\"></dd></dl>\n"
      "<p><progress id=\"progress\" max=\"1\" value=\"0\"></progress> <span "
      "id=\"progress-text\"></span></p>\n"
      "<p>processes:<span id=\"processes\"></span></p>\n"
      "<p id=\"tally\" class=\"verdict\"></p>\n"
      "<p id=\"done\" hidden>Every run is archived with its final verdict: <a id=\"report\" "
      "href=\"/\">the lot's report</a></p>\n"
      "<table class=\"data\" id=\"units\"><thead><tr><th>slot</th><th>serial</th><th>verdict</th>"
      "<th>why</th><th>state</th><th>elapsed / planned</th><th>axis</th><th>axis verdict</th>"
      "<th>BI (live)</th><th>samples</th><th>gaps</th><th>invalid</th></tr></thead>"
      "<tbody></tbody></table>\n"
      "<p class=\"note\">Provisional verdicts are lower case with a '?' (\"pending\": a value "
      "that more data can still move across a limit), final ones upper case; "
      "marks as on the console: \u00b1 1-sigma, \u2264 upper bound, \u2020 minimum not resolved, "
      "\u2021 noise model failed its fit, n/m not measurable. JSON: <a "
      "href=\"/api/live\">/api/live</a>.</p>\n"
      "<h2>Allan deviation as it grows</h2>\n<div id=\"curves\" class=\"cards\"></div>\n";
  body += "<script src=\"/assets/live.js\"></script>\n";
  return PageHtml("live station", body);
}

std::string LivePageScript() { return kLiveScript; }

}  // namespace imuqual::web
