// The inspection panel of one object (GET api/objects/{id}?with_cloud=1): its label
// distribution, observations, first and last seen, robots, and its own point cloud in a small
// orbitable view.
import * as THREE from './three_modules.js';
import { getJson, nsToDate, toId } from './api.js';
import { rgbFloats } from './colors.js';

export class InspectPanel {
  constructor(root, onClose) {
    this.root = root;
    this.view = new MiniCloudView(root.querySelector('#inspect-cloud'));
    root.querySelector('#inspect-close').addEventListener('click', () => onClose());
    this.shown = null;  // {id, className, points, labels, robots} of the last object shown
    this.wanted = null;  // the object last asked for: an older answer arriving late is dropped
  }

  async show(id) {
    this.wanted = id;
    const resp = await getJson(`api/objects/${id}?with_cloud=1`);
    if (this.wanted !== id) return;
    const o = resp.object;
    this.root.hidden = false;
    this.root.querySelector('#inspect-title').textContent =
        `${o.className} #${toId(o.id)} (${Number(o.confidence).toFixed(2)})`;
    resp.cloud = resp.cloud || [];
    resp.keyframeIds = resp.keyframeIds || [];
    this.fillFacts(o, resp);
    this.fillLabels(o.labels);
    this.view.set(resp.cloud);
    this.shown = { id: toId(o.id), className: o.className, points: resp.cloud.length,
                   labels: o.labels.map((l) => l.className), robots: o.robots };
  }

  hide() {
    this.wanted = null;
    this.root.hidden = true;
    this.shown = null;
  }

  fillFacts(o, resp) {
    const c = o.centroidM;
    const facts = [
      ['observations', `${o.observationCount} (missed ${o.missedViews})`],
      ['existence', Number(o.existence).toFixed(2)],
      ['confirmed', o.confirmed ? 'yes' : 'no'],
      ['first seen', nsToDate(o.firstSeenNs).toISOString()],
      ['last seen', nsToDate(o.lastSeenNs).toISOString()],
      ['robots', o.robots.join(', ') || '-'],
      ['last robot', o.lastRobot || '-'],
      ['centroid', `(${c.x.toFixed(2)}, ${c.y.toFixed(2)}, ${c.z.toFixed(2)}) m`],
      ['points', `${resp.cloud.length} (${resp.keyframeIds.length} keyframes)`],
    ];
    const dl = this.root.querySelector('#inspect-facts');
    dl.replaceChildren(...facts.flatMap(([k, v]) => [el('dt', k), el('dd', v)]));
  }

  fillLabels(labels) {
    const ul = this.root.querySelector('#inspect-labels');
    const sorted = [...labels].sort((a, b) => b.probability - a.probability);
    ul.replaceChildren(...sorted.map((l) => {
      const bar = el('div', '');
      bar.className = 'bar';
      bar.style.width = `${Math.round(100 * l.probability)}%`;
      const li = el('li', '');
      li.append(el('span', l.className), bar, el('span', Number(l.probability).toFixed(2)));
      return li;
    }));
  }
}

function el(tag, text) {
  const e = document.createElement(tag);
  e.textContent = text;
  return e;
}

// A second, small three.js view holding one object's points in their RGB colours.
class MiniCloudView {
  constructor(container) {
    this.container = container;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x101216);
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.01, 50);
    this.camera.up.set(0, 0, 1);
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    container.appendChild(this.renderer.domElement);
    this.controls = new THREE.OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.render());
    this.points = null;
  }

  set(cloud) {
    if (this.points) {
      this.scene.remove(this.points);
      this.points.geometry.dispose();
    }
    const xyz = new Float32Array(cloud.length * 3), rgb = new Float32Array(cloud.length * 3);
    cloud.forEach((p, i) => {
      xyz.set([p.xM, p.yM, p.zM], 3 * i);
      rgb.set(rgbFloats(p.rgb), 3 * i);
    });
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    g.setAttribute('color', new THREE.BufferAttribute(rgb, 3));
    g.computeBoundingSphere();
    this.points = new THREE.Points(g, new THREE.PointsMaterial({
      size: 0.012, vertexColors: THREE.VertexColors }));
    this.scene.add(this.points);
    this.fit(g.boundingSphere);
  }

  fit(sphere) {
    const w = this.container.clientWidth, h = this.container.clientHeight;
    this.renderer.setSize(w, h);
    this.camera.aspect = w / Math.max(1, h);
    this.camera.updateProjectionMatrix();
    const r = Math.max(0.05, sphere.radius);
    this.controls.target.copy(sphere.center);
    this.camera.position.copy(sphere.center).add(new THREE.Vector3(-2.2 * r, -1.6 * r, 1.4 * r));
    this.controls.update();
    this.render();
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }
}
