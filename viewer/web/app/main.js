// The loci web viewer: the semantic cloud, objects, trajectories, questions and live updates of
// one loci-server. `window.lociViewer` exposes a read-only summary of what the page shows (for
// tests and the console).
import { CloudLayer } from './cloud_layer.js';
import { ObjectLayer } from './object_layer.js';
import { RobotLayer } from './robot_layer.js';
import { InspectPanel } from './inspect.js';
import { followEvents } from './events.js';
import { getJson, takeTokenFromHash, toId } from './api.js';
import { describeTime, fractionOfTime, isGone, placeChanges, timeAtFraction, timeRange,
         toNs } from './timeline.js';
import { MapView } from './scene.js';
import { classColour, cssColour } from './colors.js';

const CLOUD_VOXEL_M = 0.05;
const POSE_POLL_MS = 2000;
const CLOUD_REFRESH_MS = 5000;
const SLIDER_STEPS = 1000;  // the time slider's positions (its right end is now)
const MAX_TICKS = 60;       // tick marks at the map times of changes

const state = { ready: false, answer: null, answerIds: [], selected: null, live: 'connecting',
                events: 0, errors: [], framed: false, cloudDirty: false,
                time: null, range: null, eventsOf: new Map() };
const $ = (id) => document.getElementById(id);
const view = new MapView($('view'));
const cloud = new CloudLayer(view.scene);
const objects = new ObjectLayer(view.scene, (id) => select(id));
const robots = new RobotLayer(view.scene);
const panel = new InspectPanel($('inspect'), () => select(null));

// Counts at the map time shown: objects there then (found gone ones apart), candidates, gone.
function showStatus() {
  const there = [...objects.items.values()].filter((i) => i.state);
  const gone = there.filter((i) => i.state.gone).length;
  const confirmed = there.filter((i) => !i.state.gone && objects.isConfirmed(toId(i.object.id))).length;
  const candidates = there.length - gone - confirmed;
  $('status').textContent = `${state.live}, ${confirmed} objects` +
      (candidates ? ` (+${candidates} candidates${objects.showCandidates ? '' : ', hidden'})` : '') +
      (gone ? `, ${gone} gone` : '') + (state.time === null ? '' : ', in the past');
}

function report(where, e) {
  state.errors.push(`${where}: ${e.message}`);
  $('status').textContent = `${where}: ${e.message}`;
}

function colourMode() {
  return $('colour-rgb').checked ? 'rgb' : 'label';
}

function recolour() {
  cloud.colour(colourMode(), (id) => objects.classOf(id));
  updateLegend();
}

function updateLegend() {
  const classes = [...new Set(objects.shownItems().map((i) => i.object.className))].sort();
  $('legend').replaceChildren(...classes.map((c) => {
    const s = document.createElement('span');
    const i = document.createElement('i');
    i.style.background = cssColour(classColour(c));
    s.append(i, c);
    return s;
  }));
}

async function loadObjects() {
  const resp = await getJson('api/objects?include_removed=1');
  objects.clear();
  for (const o of resp.objects) objects.upsert(o);
  objects.setHighlighted(state.answerIds);
  objects.setSelected(state.selected);
  updateTimeline();
  recolour();
  showStatus();
}

// The slider's span (oldest first sighting to newest stamp), position, label and ticks.
function updateTimeline() {
  const held = [...objects.items.values()].map((i) => i.object);
  state.range = timeRange(held);
  if (state.time !== null && (!state.range || state.time >= state.range.maxNs)) showTime(null);
  const slider = $('time');
  slider.disabled = !state.range || state.range.maxNs <= state.range.minNs;
  slider.value = String(Math.round(fractionOfTime(state.range, state.time) * SLIDER_STEPS));
  $('time-label').textContent = describeTime(state.range, state.time);
  const stamps = new Set(held.flatMap((o) => placeChanges(o).map((c) =>
    Math.round(fractionOfTime(state.range, c.tNs) * SLIDER_STEPS))));
  $('time-ticks').replaceChildren(...[...stamps].sort((a, b) => a - b).slice(0, MAX_TICKS)
    .map((v) => Object.assign(document.createElement('option'), { value: String(v) })));
}

// Shows the map at map time `t` (BigInt ns; null = now).
function showTime(t) {
  state.time = t;
  objects.setTime(t);
  $('time-now').disabled = t === null;
  $('time-label').textContent = describeTime(state.range, t);
  updateLegend();
  showStatus();
}

function setTime(t) {
  showTime(t === null || !state.range || t >= state.range.maxNs ? null : t);
  $('time').value = String(Math.round(fractionOfTime(state.range, state.time) * SLIDER_STEPS));
}

async function loadCloud() {
  state.cloudDirty = false;
  cloud.set(await getJson(`api/cloud?voxel_m=${CLOUD_VOXEL_M}`), CLOUD_VOXEL_M);
  recolour();
  const box = cloud.bounds() || objects.bounds();
  if (!box) return;
  view.setFloor(box);
  if (!state.framed) {
    view.frame(box);
    state.framed = true;
  }
}

async function loadPoses() {
  robots.set((await getJson('api/trajectories')).trajectories);
}

function applyEvent(e) {
  state.events += 1;
  state.cloudDirty = true;
  const id = toId(e.object.id);
  countEvent(id);
  if (e.kind === 'REMOVED') applyRemoved(id, e);
  else objects.upsert(e.object);  // CREATED, UPDATED, MERGED, MOVED (its history has the move)
  if (e.kind === 'MERGED') {
    countEvent(toId(e.mergedFromId));
    objects.remove(toId(e.mergedFromId));
  }
  afterObjectsChanged();
  if (state.selected === id && e.kind !== 'REMOVED') panel.show(id).catch((x) => report('inspect', x));
}

function afterObjectsChanged() {
  objects.setHighlighted(state.answerIds);
  updateTimeline();
  recolour();
  showStatus();
}

function countEvent(id) {
  state.eventsOf.set(id, (state.eventsOf.get(id) || 0) + 1);
}

// REMOVED: absorbed by a merge, or a candidate that faded: it leaves the page. Found gone (the
// event's object says so): it stays as a ghost. A removal with evidence that does not say so
// (the event may carry the last state without its history) is asked about.
function applyRemoved(id, e) {
  if (isGone(e.object)) return objects.upsert(e.object);
  objects.remove(id);
  if ((e.evidenceKeyframeIds || []).length) {
    fetchGone(id).catch((x) => { if (x.status !== 404) report('objects', x); });
  }
}

// GetObject of a removed id: its last state when it was found gone (an id that a move or merge
// handed on resolves to another object: not this one). Dropped when an event about the id
// arrived meanwhile.
async function fetchGone(id) {
  const seen = state.eventsOf.get(id);
  const o = (await getJson(`api/objects/${id}`)).object;
  if (state.eventsOf.get(id) !== seen || toId(o.id) !== id || !isGone(o)) return;
  objects.upsert(o);
  afterObjectsChanged();
}

async function ask(question) {
  const box = $('answer');
  try {
    const resp = await getJson('api/ask?q=' + encodeURIComponent(question));
    for (const o of resp.objects) {
      if (!objects.items.has(toId(o.id))) objects.upsert(o);
    }
    state.answer = resp.answer;
    state.answerIds = resp.objects.map((o) => toId(o.id));
    box.classList.remove('error');
    box.textContent = resp.answer;
  } catch (e) {
    state.answer = null;
    state.answerIds = [];
    box.classList.add('error');
    box.textContent = e.message;
  }
  box.hidden = false;
  objects.setHighlighted(state.answerIds);
  updateLegend();
}

function select(id) {
  state.selected = id;
  objects.setSelected(id);
  if (id === null) return panel.hide();
  panel.show(id).catch((e) => report('inspect', e));
}

function wireInput() {
  $('ask-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    const q = $('question').value.trim();
    if (q) ask(q);
  });
  $('colour-rgb').addEventListener('change', recolour);
  $('time').addEventListener('input', () => {
    showTime(timeAtFraction(state.range, Number($('time').value) / SLIDER_STEPS));
  });
  $('time-now').addEventListener('click', () => setTime(null));
  $('show-candidates').addEventListener('change', () => {
    objects.setShowCandidates($('show-candidates').checked);
    updateLegend();
    showStatus();
  });
  let down = null;
  const canvas = view.renderer.domElement;
  canvas.addEventListener('pointerdown', (ev) => { down = [ev.clientX, ev.clientY]; });
  canvas.addEventListener('click', (ev) => {
    if (down && Math.hypot(ev.clientX - down[0], ev.clientY - down[1]) > 5) return;  // a drag
    const hit = view.pick(ev.clientX, ev.clientY, objects.pickables());
    select(hit ? hit.userData.objectId : null);
  });
}

function every(ms, job) {
  setInterval(() => job().catch((e) => report(job.name, e)), ms);
}

async function main() {
  takeTokenFromHash();
  wireInput();
  view.start(() => {});
  await Promise.all([loadObjects(), loadPoses()]);
  await loadCloud();
  state.ready = true;
  $('status').textContent = 'connecting';
  every(POSE_POLL_MS, loadPoses);
  every(CLOUD_REFRESH_MS, async function refreshCloud() { if (state.cloudDirty) await loadCloud(); });
  followEvents({
    onReady: () => loadObjects().catch((e) => report('objects', e)),
    onEvent: applyEvent,
    onState: (s) => { state.live = s; showStatus(); },
  });
}

window.lociViewer = Object.freeze({
  get ready() { return state.ready; },
  get live() { return state.live; },
  get eventsReceived() { return state.events; },
  get errors() { return [...state.errors]; },
  get objects() {
    return [...objects.items.values()].map(({ object: o }) => ({
      id: toId(o.id), className: o.className, confidence: o.confidence, confirmed: o.confirmed,
      shown: objects.isShown(toId(o.id)), ...objects.placeSummary(toId(o.id)) }))
        .sort((a, b) => a.id - b.id);
  },
  // The time slider's span (int64 strings, like the API's stamps), or null without objects.
  get timeRange() {
    const r = state.range;
    return r ? { minNs: String(r.minNs), maxNs: String(r.maxNs) } : null;
  },
  get time() { return state.time === null ? null : String(state.time); },  // null = now
  get timeLabel() { return $('time-label').textContent; },
  // Shows the map at map time `ns` (an int64 string or number; null = now), slider included.
  setTime(ns) { setTime(ns === null ? null : toNs(ns)); },
  get showCandidates() { return objects.showCandidates; },
  get highlighted() { return [...objects.highlighted].sort((a, b) => a - b); },
  get answer() { return state.answer; },
  get selected() { return state.selected; },
  get inspected() { return panel.shown ? { ...panel.shown } : null; },
  get robots() { return robots.summary(); },
  get cloudPoints() { return cloud.count; },
  get colourMode() { return cloud.mode; },
  // Client pixel of object `id`'s centroid where it is drawn (for clicking it), or null.
  screenPosition(id) {
    const item = objects.items.get(id);
    return item ? view.toClient(item.state ? item.state.at : item.object.centroidM) : null;
  },
});

main().catch((e) => report('load', e));
