// The map's objects: an oriented box each (its OBB in the map frame), a label with class, id and
// confidence, highlighted when an answer names it, outlined when selected. Candidates (objects
// not confirmed yet) are hidden unless showCandidates is set, or an answer names them, or they
// are selected.
import * as THREE from './three_modules.js';
import { HIGHLIGHT, classColour, cssColour } from './colors.js';
import { toId } from './api.js';

export class ObjectLayer {
  constructor(scene, onLabelClick) {
    this.group = new THREE.Group();
    scene.add(this.group);
    this.onLabelClick = onLabelClick;
    this.items = new Map();  // id -> {object, box, fill, label}
    this.highlighted = new Set();
    this.selected = null;
    this.showCandidates = false;
  }

  setShowCandidates(show) {
    this.showCandidates = show;
    for (const id of this.items.keys()) this.restyle(id);
  }

  isShown(id) {
    const item = this.items.get(id);
    return !!item && (item.object.confirmed || this.showCandidates || this.highlighted.has(id) ||
                      id === this.selected);
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
                                       new THREE.LineBasicMaterial({ color: colour }));
    const fill = new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({
      color: colour, transparent: true, opacity: 0.1, depthWrite: false }));
    fill.userData.objectId = id;
    const holder = new THREE.Group();
    const q = o.obb.RMapBox || {};
    holder.position.set(o.obb.centerM.x, o.obb.centerM.y, o.obb.centerM.z);
    if (q.qw || q.qx || q.qy || q.qz) holder.quaternion.set(q.qx, q.qy, q.qz, q.qw).normalize();
    holder.add(box, fill);
    const label = this.makeLabel(o, id, colour);
    label.position.set(o.centroidM.x, o.centroidM.y, o.aabb.maxM.z + 0.08);
    this.group.add(holder, label);
    this.items.set(id, { object: o, holder, box, fill, label });
    this.restyle(id);
  }

  makeLabel(o, id, colour) {
    const div = document.createElement('div');
    div.className = 'label' + (o.confirmed ? '' : ' unconfirmed');
    div.textContent = `${o.className} #${id} ${Number(o.confidence).toFixed(2)}`;
    div.style.borderColor = cssColour(colour);
    div.dataset.objectId = String(id);
    div.addEventListener('click', () => this.onLabelClick(id));
    return new THREE.CSS2DObject(div);
  }

  remove(id) {
    const item = this.items.get(id);
    if (!item) return;
    this.group.remove(item.holder, item.label);
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
    item.box.material.color.setHex(hl ? HIGHLIGHT : classColour(item.object.className));
    item.fill.material.color.setHex(hl ? HIGHLIGHT : classColour(item.object.className));
    item.fill.material.opacity = hl ? 0.35 : (id === this.selected ? 0.25 : 0.1);
    item.label.element.classList.toggle('highlight', hl);
    item.label.element.classList.toggle('selected', id === this.selected);
    const shown = this.isShown(id);
    item.holder.visible = shown;
    item.label.visible = shown;
    if (!shown) item.label.element.style.display = 'none';  // until the next frame renders it
  }

  pickables() {
    return this.shownItems().map((i) => i.fill);
  }

  classOf(id) {
    const item = this.items.get(id);
    return item ? item.object.className : null;
  }

  bounds() {
    const box = new THREE.Box3();
    for (const item of this.shownItems()) box.expandByObject(item.holder);
    return box.isEmpty() ? null : box;
  }
}
