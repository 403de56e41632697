// The view's page scripts: the live panes (a WebSocket pushes the snapshot) and the episode page. Data is
// written as text, never as HTML.
'use strict';

const dhToken = new URLSearchParams(location.search).get('token');
const withToken = (url) => dhToken ? url + (url.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(dhToken) : url;

function cell(tr, text, cls) {
  const td = document.createElement('td');
  td.textContent = text === undefined || text === null ? '' : String(text);
  if (cls) td.className = cls;
  tr.appendChild(td);
  return td;
}

function percent(x) { return x === null || x === undefined ? '–' : (100 * x).toFixed(1) + ' %'; }
function duration(s) {
  if (s === null || s === undefined) return '–';
  s = Math.round(s);
  return s < 60 ? s + 's' : s < 3600 ? Math.floor(s / 60) + 'm' + String(s % 60).padStart(2, '0') + 's'
                                     : Math.floor(s / 3600) + 'h' + String(Math.floor(s / 60) % 60).padStart(2, '0');
}

function renderChannels(channels) {
  const body = document.querySelector('#channels tbody');
  body.replaceChildren();
  for (const c of channels) {
    const tr = document.createElement('tr');
    tr.dataset.channel = c.channel;
    cell(tr, c.host);
    cell(tr, c.channel);
    cell(tr, c.state, 'state-' + c.state);
    const ep = cell(tr, '');
    if (c.episode_id) {
      if (c.evidence) {
        const a = document.createElement('a');
        a.href = withToken('/episode?evidence=' + encodeURIComponent(c.evidence));
        a.textContent = c.episode_id;
        ep.appendChild(a);
      } else {
        ep.textContent = c.episode_id;
      }
    }
    cell(tr, c.arm);
    cell(tr, c.cell);
    cell(tr, c.task);
    cell(tr, c.seed);
    cell(tr, c.step === undefined ? '' : c.step + ' / ' + c.budget_steps, 'step');
    cell(tr, c.capability);
    cell(tr, c.outcome ? c.outcome : c.decision);
    cell(tr, c.reason, 'reason');
    body.appendChild(tr);
  }
}

function renderCampaigns(campaigns) {
  const box = document.getElementById('campaigns');
  box.replaceChildren();
  box.className = campaigns.length ? '' : 'muted';
  if (!campaigns.length) box.textContent = 'no campaign heard of yet';
  for (const c of campaigns) {
    const div = document.createElement('div');
    div.className = 'campaign';
    const title = document.createElement('p');
    const bar = document.createElement('span');
    bar.className = 'bar';
    const fill = document.createElement('span');
    fill.style.width = (c.total ? 100 * c.done / c.total : 0) + '%';
    bar.appendChild(fill);
    title.append(c.campaign + '  ', bar,
                 `  ${c.done} / ${c.total}  ·  ${c.rate_per_s === null ? '–' : c.rate_per_s.toFixed(2)} ep/s  ·  ETA ` +
                 `${c.finished ? 'done' : duration(c.eta_s)}  ·  lost ${c.infrastructure}, rerun ${c.reran}`);
    div.appendChild(title);
    const t = document.createElement('table');
    const head = document.createElement('tr');
    for (const h of ['Arm', 'Cell', 'Successes', 'Episodes', 'Rate', 'Wilson 95 %']) cell(head, h);
    t.appendChild(head);
    for (const k of c.cells) {
      const tr = document.createElement('tr');
      cell(tr, k.arm);
      cell(tr, k.cell);
      cell(tr, k.successes);
      cell(tr, k.episodes);
      cell(tr, percent(k.rate));
      cell(tr, k.episodes ? '[' + percent(k.wilson_lo) + ', ' + percent(k.wilson_hi) + ']' : '–');
      t.appendChild(tr);
    }
    div.appendChild(t);
    box.appendChild(div);
  }
}

function dhLive() {
  let updates = 0;
  const link = document.getElementById('link');
  const open = () => {
    const ws = new WebSocket(withToken((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/ws'));
    ws.onopen = () => { link.textContent = 'live'; link.className = 'state-running'; };
    ws.onmessage = (m) => {
      const s = JSON.parse(m.data);
      if (s.error) { link.textContent = s.error; link.className = 'error'; return; }
      renderChannels(s.channels);
      renderCampaigns(s.campaigns);
      document.getElementById('updates').textContent = (++updates) + ' updates';
    };
    ws.onclose = () => { link.textContent = 'disconnected, retrying…'; link.className = 'error'; setTimeout(open, 1000); };
  };
  open();
}

function describe(e) {
  switch (e.kind) {
    case 'advice': return e.refused ? 'planner refused: ' + (e.reason || '') : e.done ? 'planner: done'
                        : 'planner: ' + (e.capability || '') + ' ' + JSON.stringify(e.args || {});
    case 'grounding': return 'grounded ' + JSON.stringify(e.args || {}) + '  θ ' + JSON.stringify(e.theta || {});
    case 'refusal': return (e.refusal || e.state || 'refused') + ': ' + (e.reason || '');
    case 'dispatch': return 'to ' + (e.instance || '') + ', budget ' + e.budget_steps + ' steps';
    case 'decision': return e.decision + ': ' + (e.reason || '');
    case 'command_end': return e.state + (e.failure && e.failure !== 'none' ? ' (' + e.failure + (e.stage ? ' at ' + e.stage : '') + ')' : '') + (e.reason ? ': ' + e.reason : '');
    case 'verdict': return e.predicate + ' ' + (e.value ? 'holds' : 'no longer holds');
    case 'end': return e.outcome + (e.latched ? ' (verdict latched)' : '') + ': ' + (e.reason || '');
  }
  return '';
}

async function dhEpisode() {
  const evidence = new URLSearchParams(location.search).get('evidence') || '';
  const summary = document.getElementById('summary');
  const home = document.getElementById('home');
  home.href = withToken('/');
  let page;
  try {
    const r = await fetch(withToken('/api/episode?evidence=' + encodeURIComponent(evidence)));
    page = await r.json();
    if (!r.ok || page.error) throw new Error(page.error || r.statusText);
  } catch (err) {
    summary.className = 'error';
    summary.textContent = 'This episode cannot be shown: ' + err.message;
    document.getElementById('film-note').textContent = 'no filmstrip without the evidence.';
    return;
  }
  document.title = 'DynaHarness ' + page.episode_id;
  summary.className = '';
  const lines = [
    page.episode_id + '  —  "' + page.instruction + '"',
    `arm ${page.arm}, cell ${page.cell}, task ${page.task}, seed ${page.seed}; ${page.outcome} at step ${page.end_step} of ` +
      `${page.budget_steps}` + (page.latched ? `, verdict latched (held from step ${page.verdict_step})` : '') +
      `; ${page.safety_holds} safety holds; library ${page.library_version}`,
  ];
  if (page.attribution) lines.push(page.attribution.error ? 'attribution: ' + page.attribution.error
    : `attribution: layer ${page.attribution.layer + 1} ${page.attribution.name} (${page.attribution.harness ? 'the harness' : 'not the harness'})` +
      (page.attribution.capability ? `, ${page.attribution.capability} ${page.attribution.failure} at step ${page.attribution.step}` : ''));
  summary.replaceChildren(...lines.map((l) => { const p = document.createElement('p'); p.textContent = l; return p; }));
  const axis = document.getElementById('axis');
  const span = Math.max(1, page.budget_steps || page.end_step || 1);
  const body = document.querySelector('#timeline tbody');
  for (const e of page.events) {
    const tr = document.createElement('tr');
    tr.className = 'kind-' + e.kind;
    cell(tr, e.step);
    cell(tr, e.kind === 'decision' ? e.decision : e.kind);
    cell(tr, e.capability);
    cell(tr, describe(e), 'what');
    body.appendChild(tr);
    if (e.step !== null && e.step !== undefined) {
      const tick = document.createElement('i');
      tick.className = 'kind-' + e.kind;
      tick.style.left = (100 * e.step / span) + '%';
      tick.title = 'step ' + e.step + ': ' + describe(e);
      axis.appendChild(tick);
    }
  }
  const img = document.getElementById('film');
  const note = document.getElementById('film-note');
  img.onload = () => { note.textContent = 'steps chosen automatically: refusals, recoveries, each command, the verdict.'; };
  img.onerror = async () => {
    try { const r = await fetch(img.src); const j = await r.json(); note.textContent = 'no filmstrip: ' + j.error; }
    catch (err) { note.textContent = 'no filmstrip.'; }
    note.className = 'error';
  };
  img.src = withToken('/api/film?evidence=' + encodeURIComponent(evidence));
}
