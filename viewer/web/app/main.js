// The loci web viewer: the semantic cloud, objects, trajectories, questions and live updates of
// one loci-server. `window.lociViewer` exposes a read-only summary of what the page shows (for
// tests and the console).
import { CloudLayer } from './cloud_layer.js';
import { ObjectLayer } from './object_layer.js';
import { RobotLayer } from './robot_layer.js';
import { InspectPanel } from './inspect.js';
import { followEvents } from './events.js';
import { getJson, takeTokenFromHash, toId } from './api.js';
import { MapView } from './scene.js';
import { classColour, cssColour } from './colors.js';

const CLOUD_VOXEL_M = 0.05;
const POSE_POLL_MS = 2000;
const CLOUD_REFRESH_MS = 5000;

const state = { ready: false, answer: null, answerIds: [], selected: null, live: 'connecting',
                events: 0, errors: [], framed: false, cloudDirty: false };
const $ = (id) => document.getElementById(id);
const view = new MapView($('view'));
const cloud = new CloudLayer(view.scene);
const objects = new ObjectLayer(view.scene, (id) => select(id));
const robots = new RobotLayer(view.scene);
const panel = new InspectPanel($('inspect'), () => select(null));

function showStatus() {
  const confirmed = [...objects.items.values()].filter((i) => i.object.confirmed).length;
  const candidates = objects.items.size - confirmed;
  $('status').textContent = `${state.live}, ${confirmed} objects` +
      (candidates ? ` (+${candidates} candidates${objects.showCandidates ? '' : ', hidden'})` : '');
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
  const resp = await getJson('api/objects');
  objects.clear();
  for (const o of resp.objects) objects.upsert(o);
  objects.setHighlighted(state.answerIds);
  objects.setSelected(state.selected);
  recolour();
  showStatus();
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
  if (e.kind === 'REMOVED') objects.remove(id);
  else objects.upsert(e.object);
  if (e.kind === 'MERGED') objects.remove(toId(e.mergedFromId));
  objects.setHighlighted(state.answerIds);
  recolour();
  showStatus();
  if (state.selected === id && e.kind !== 'REMOVED') panel.show(id).catch((x) => report('inspect', x));
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
      shown: objects.isShown(toId(o.id)) }))
        .sort((a, b) => a.id - b.id);
  },
  get showCandidates() { return objects.showCandidates; },
  get highlighted() { return [...objects.highlighted].sort((a, b) => a - b); },
  get answer() { return state.answer; },
  get selected() { return state.selected; },
  get inspected() { return panel.shown ? { ...panel.shown } : null; },
  get robots() { return robots.summary(); },
  get cloudPoints() { return cloud.count; },
  get colourMode() { return cloud.mode; },
  // Client pixel of object `id`'s centroid (for clicking it), or null.
  screenPosition(id) {
    const item = objects.items.get(id);
    return item ? view.toClient(item.object.centroidM) : null;
  },
});

main().catch((e) => report('load', e));
