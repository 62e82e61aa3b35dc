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
import { isGone, stateAt } from './timeline.js';

const GHOST_OPACITY = 0.75;  // a ghost's dashed outline
const GHOST_FILL = 0.05;
const TRAIL_COLOUR = 0xe8e8e8;  // the dashed line from an earlier place to the next

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
    return this.isConfirmed(id) || this.showCandidates || this.highlighted.has(id) ||
           id === this.selected;
  }

  // Confirmed, or found gone later (a confirmed object whose belief fell), so shown solid
  // before its removal.
  isConfirmed(id) {
    const o = this.items.get(id).object;
    return !!o.confirmed || isGone(o);
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
    const ghostBox = ghostOutline(box.geometry, colour);  // drawn instead of `box` once gone
    const fill = new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({
      color: colour, transparent: true, opacity: 0.1, depthWrite: false }));
    fill.userData.objectId = id;
    const holder = new THREE.Group();
    const q = o.obb.RMapBox || {};
    if (q.qw || q.qx || q.qy || q.qz) holder.quaternion.set(q.qx, q.qy, q.qz, q.qw).normalize();
    holder.add(box, ghostBox, fill);
    const label = this.makeLabel(id, colour);
    const trail = new THREE.Group();
    this.group.add(holder, label, trail);
    this.items.set(id, { object: o, holder, box, ghostBox, fill, label, trail, state: null });
    this.place(id);
  }

  makeLabel(id, colour, className = 'label') {
    const div = document.createElement('div');
    div.className = className;
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
    div.classList.toggle('unconfirmed', !this.isConfirmed(id));
    div.classList.toggle('gone', !!state && state.gone);
    this.restyle(id);
  }

  // The OBB's centre when the centroid stands at `at` (the box keeps its offset and turn).
  boxCentreAt(o, at) {
    const c = o.obb.centerM;
    return new THREE.Vector3(c.x + at.x - o.centroidM.x, c.y + at.y - o.centroidM.y,
                             c.z + at.z - o.centroidM.z);
  }

  // At each earlier place a ghost (a dashed outline of the box and a faint label "earlier"),
  // and a dashed line from it to the next place.
  buildTrail(item) {
    this.disposeTrail(item);
    if (!item.state) return;
    const o = item.object, id = toId(o.id);
    const colour = classColour(o.className);
    for (const g of item.state.ghosts) {
      const ghost = ghostOutline(item.box.geometry, colour);
      ghost.position.copy(this.boxCentreAt(o, g.from));
      ghost.quaternion.copy(item.holder.quaternion);
      const line = new THREE.Line(
          new THREE.BufferGeometry().setFromPoints([vec(g.from), vec(g.to)]),
          new THREE.LineDashedMaterial({ color: TRAIL_COLOUR, dashSize: 0.05, gapSize: 0.035,
                                         depthTest: false, transparent: true }));
      line.computeLineDistances();
      const label = this.makeLabel(id, colour, 'label ghost');
      label.element.textContent = `${o.className} #${id} earlier`;
      delete label.element.dataset.objectId;  // that names the object's own label
      label.element.dataset.ghostOf = String(id);
      label.position.set(g.from.x, g.from.y, o.aabb.maxM.z + (g.from.z - o.centroidM.z) + 0.08);
      item.trail.add(ghost, line, label);
    }
  }

  disposeTrail(item) {
    for (const part of [...item.trail.children]) {
      item.trail.remove(part);
      if (part.element) {
        part.element.remove();  // a label
      } else {
        part.geometry.dispose();
        part.material.dispose();
      }
    }
  }

  remove(id) {
    const item = this.items.get(id);
    if (!item) return;
    this.disposeTrail(item);
    this.group.remove(item.holder, item.label, item.trail);
    item.label.element.remove();
    for (const mesh of [item.box, item.ghostBox, item.fill]) {
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
    item.box.visible = !gone;
    item.ghostBox.material.color.setHex(colour);
    item.ghostBox.visible = gone;
    item.fill.material.color.setHex(colour);
    item.fill.material.opacity = hl ? 0.35 : (id === this.selected ? 0.25 : (gone ? GHOST_FILL : 0.1));
    item.label.element.classList.toggle('highlight', hl);
    item.label.element.classList.toggle('selected', id === this.selected);
    const shown = this.isShown(id);
    item.holder.visible = shown;
    item.label.visible = shown;
    item.trail.visible = shown;
    if (!shown) {  // until the next frame renders them
      for (const label of [item.label, ...item.trail.children.filter((c) => c.element)]) {
        label.element.style.display = 'none';
      }
    }
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

// A box's edges as a dashed, faded outline drawn over the cloud: a ghost (a place the object is
// no longer at).
function ghostOutline(edges, colour) {
  const outline = new THREE.LineSegments(edges.clone(), new THREE.LineDashedMaterial({
    color: colour, dashSize: 0.03, gapSize: 0.02, transparent: true, opacity: GHOST_OPACITY,
    depthTest: false, depthWrite: false }));  // seen through the points that hide its place
  outline.computeLineDistances();
  return outline;
}
