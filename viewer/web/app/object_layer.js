// The map's objects: an oriented box each (its OBB in the map frame), a label with class, id and
// confidence, highlighted when an answer names it, outlined when selected. Candidates (objects
// not confirmed yet) are hidden unless showCandidates is set, or an answer names them, or they
// are selected.
//
// Changes over time (timeline.js): the layer shows the map at one map time (`setTime`, null =
// now). A moved object stands at its place then, with a faded ghost box at each earlier place
// it moved away from and a dashed line to where it went; an object found gone is itself a
// faded ghost at its last place, labelled "(gone)"; an object that had not appeared yet is not
// drawn.
import * as THREE from './three_modules.js';
import { HIGHLIGHT, classColour, cssColour } from './colors.js';
import { toId } from './api.js';
import { stateAt } from './timeline.js';

const GHOST_OPACITY = 0.35;
const TRAIL_OPACITY = 0.7;

export class ObjectLayer {
  constructor(scene, onLabelClick) {
    this.group = new THREE.Group();
    scene.add(this.group);
    this.onLabelClick = onLabelClick;
    this.items = new Map();  // id -> {object, holder, box, fill, label, trail, state}
    this.highlighted = new Set();
    this.selected = null;
    this.showCandidates = false;
    this.time = null;  // the map time shown (BigInt ns), null = now
  }

  setShowCandidates(show) {
    this.showCandidates = show;
    for (const id of this.items.keys()) this.restyle(id);
  }

  // Shows the map as it was at map time `t` (BigInt ns; null = now).
  setTime(t) {
    this.time = t;
    for (const id of this.items.keys()) this.place(id);
  }

  // Drawn at the time shown: it had appeared, and it is confirmed, found gone (a ghost), named
  // by the answer or selected, or candidates are shown.
  isShown(id) {
    const item = this.items.get(id);
    if (!item || !item.state) return false;
    return item.object.confirmed || item.state.gone || this.showCandidates ||
           this.highlighted.has(id) || id === this.selected;
  }

  isGone(id) {
    const item = this.items.get(id);
    return !!item && !!item.state && item.state.gone;
  }

  shownItems() {
    return [...this.items.entries()].filter(([id]) => this.isShown(id)).map(([, item]) => item);
  }

  upsert(o) {
    const id = toId(o.id);
    this.remove(id);
    const colour = classColour(o.className);
    const half = o.obb.halfExtentM;
    const geometry = new THREE.BoxBufferGeometry(2 * half.x, 2 * half.y, 2 * half.z);
    const box = new THREE.LineSegments(new THREE.EdgesGeometry(geometry),
                                       new THREE.LineBasicMaterial({ color: colour, transparent: true }));
    const fill = new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({
      color: colour, transparent: true, opacity: 0.1, depthWrite: false }));
    fill.userData.objectId = id;
    const holder = new THREE.Group();
    const q = o.obb.RMapBox || {};
    if (q.qw || q.qx || q.qy || q.qz) holder.quaternion.set(q.qx, q.qy, q.qz, q.qw).normalize();
    holder.add(box, fill);
    const label = this.makeLabel(id, colour);
    const trail = new THREE.Group();
    this.group.add(holder, label, trail);
    this.items.set(id, { object: o, holder, box, fill, label, trail, state: null });
    this.place(id);
  }

  makeLabel(id, colour) {
    const div = document.createElement('div');
    div.className = 'label';
    div.style.borderColor = cssColour(colour);
    div.dataset.objectId = String(id);
    div.addEventListener('click', () => this.onLabelClick(id));
    return new THREE.CSS2DObject(div);
  }

  // Puts the box, label and ghosts where the object was at the time shown.
  place(id) {
    const item = this.items.get(id);
    const o = item.object;
    const state = stateAt(o, this.time);
    const ghostsBefore = item.state ? item.state.ghosts.length : -1;
    item.state = state;
    if (state) {
      item.holder.position.copy(this.boxCentreAt(o, state.at));
      item.label.position.set(state.at.x, state.at.y,
                              o.aabb.maxM.z + (state.at.z - o.centroidM.z) + 0.08);
    }
    if (!state || state.ghosts.length !== ghostsBefore) this.buildTrail(item);
    const div = item.label.element;
    div.textContent = state && state.gone ? `${o.className} #${id} (gone)`
                                          : `${o.className} #${id} ${Number(o.confidence).toFixed(2)}`;
    div.classList.toggle('unconfirmed', !o.confirmed && !(state && state.gone));
    div.classList.toggle('gone', !!state && state.gone);
    this.restyle(id);
  }

  // The OBB's centre when the centroid stands at `at` (the box keeps its offset and turn).
  boxCentreAt(o, at) {
    const c = o.obb.centerM;
    return new THREE.Vector3(c.x + at.x - o.centroidM.x, c.y + at.y - o.centroidM.y,
                             c.z + at.z - o.centroidM.z);
  }

  // A faded box at each earlier place and a dashed line from it to the next place.
  buildTrail(item) {
    this.disposeTrail(item);
    if (!item.state) return;
    const colour = classColour(item.object.className);
    for (const g of item.state.ghosts) {
      const ghost = new THREE.LineSegments(item.box.geometry.clone(), new THREE.LineBasicMaterial({
        color: colour, transparent: true, opacity: GHOST_OPACITY, depthWrite: false }));
      ghost.position.copy(this.boxCentreAt(item.object, g.from));
      ghost.quaternion.copy(item.holder.quaternion);
      const line = new THREE.Line(
          new THREE.BufferGeometry().setFromPoints([vec(g.from), vec(g.to)]),
          new THREE.LineDashedMaterial({ color: colour, dashSize: 0.06, gapSize: 0.04,
                                         transparent: true, opacity: TRAIL_OPACITY }));
      line.computeLineDistances();
      item.trail.add(ghost, line);
    }
  }

  disposeTrail(item) {
    for (const part of [...item.trail.children]) {
      item.trail.remove(part);
      part.geometry.dispose();
      part.material.dispose();
    }
  }

  remove(id) {
    const item = this.items.get(id);
    if (!item) return;
    this.disposeTrail(item);
    this.group.remove(item.holder, item.label, item.trail);
    item.label.element.remove();
    for (const mesh of [item.box, item.fill]) {
      mesh.geometry.dispose();
      mesh.material.dispose();
    }
    this.items.delete(id);
  }

  clear() {
    for (const id of [...this.items.keys()]) this.remove(id);
  }

  setHighlighted(ids) {
    this.highlighted = new Set(ids);
    for (const id of this.items.keys()) this.restyle(id);
  }

  setSelected(id) {
    this.selected = id;
    for (const key of this.items.keys()) this.restyle(key);
  }

  restyle(id) {
    const item = this.items.get(id);
    const hl = this.highlighted.has(id);
    const gone = this.isGone(id);
    const colour = hl ? HIGHLIGHT : classColour(item.object.className);
    item.box.material.color.setHex(colour);
    item.box.material.opacity = gone && !hl ? GHOST_OPACITY : 1;
    item.fill.material.color.setHex(colour);
    item.fill.material.opacity = hl ? 0.35 : (id === this.selected ? 0.25 : (gone ? 0.03 : 0.1));
    item.label.element.classList.toggle('highlight', hl);
    item.label.element.classList.toggle('selected', id === this.selected);
    const shown = this.isShown(id);
    item.holder.visible = shown;
    item.label.visible = shown;
    item.trail.visible = shown;
    if (!shown) item.label.element.style.display = 'none';  // until the next frame renders it
  }

  pickables() {
    return this.shownItems().map((i) => i.fill);
  }

  classOf(id) {
    const item = this.items.get(id);
    return item ? item.object.className : null;
  }

  // {gone, shownAt: {x, y, z} (the centroid drawn), ghosts (how many earlier places are drawn),
  // ghostsAt: [{x, y, z}] (their centroids)} at the time shown; shownAt null and no ghosts when
  // the object had not appeared yet.
  placeSummary(id) {
    const s = this.items.get(id).state;
    const xyz = (p) => ({ x: p.x, y: p.y, z: p.z });
    return { gone: !!s && s.gone, shownAt: s ? xyz(s.at) : null, ghosts: s ? s.ghosts.length : 0,
             ghostsAt: s ? s.ghosts.map((g) => xyz(g.from)) : [] };
  }

  bounds() {
    const box = new THREE.Box3();
    for (const item of this.shownItems()) box.expandByObject(item.holder);
    return box.isEmpty() ? null : box;
  }
}

const vec = (p) => new THREE.Vector3(p.x, p.y, p.z);
