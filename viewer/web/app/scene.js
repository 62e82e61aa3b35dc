// The 3D view: renderer, camera orbiting in the z-up map frame (REP-103: x forward, y left,
// z up), a floor grid, label overlay, and picking of what lies under a click.
import * as THREE from './three_modules.js';

export class MapView {
  constructor(container) {
    this.container = container;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x16181d);
    this.camera = new THREE.PerspectiveCamera(55, 1, 0.02, 500);
    this.camera.up.set(0, 0, 1);  // before the controls read it
    this.camera.position.set(-4, -3, 3);
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    container.appendChild(this.renderer.domElement);
    this.labels = new THREE.CSS2DRenderer();
    Object.assign(this.labels.domElement.style, { position: 'absolute', top: '0', left: '0',
                                                  pointerEvents: 'none' });
    container.appendChild(this.labels.domElement);
    this.controls = new THREE.OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = false;
    this.grid = null;
    this.scene.add(new THREE.AxesHelper(0.5));
    window.addEventListener('resize', () => this.resize());
    this.resize();
    this.setFloor(new THREE.Box3(new THREE.Vector3(-3, -3, -1.5), new THREE.Vector3(3, 3, 1)));
  }

  resize() {
    const w = this.container.clientWidth, h = this.container.clientHeight;
    this.camera.aspect = w / Math.max(1, h);
    this.camera.updateProjectionMatrix();
    this.renderer.setSize(w, h);
    this.labels.setSize(w, h);
  }

  // A 1 m grid on the floor (the bottom of `box`), covering the box with a margin.
  setFloor(box) {
    if (this.grid) this.scene.remove(this.grid);
    const size = 2 * Math.ceil(Math.max(box.max.x - box.min.x, box.max.y - box.min.y) / 2 + 1);
    this.grid = new THREE.GridHelper(size, size, 0x5a6070, 0x353a44);
    this.grid.rotation.x = Math.PI / 2;  // GridHelper lies in x-z; the map floor is x-y
    const c = box.getCenter(new THREE.Vector3());
    this.grid.position.set(Math.round(c.x), Math.round(c.y), box.min.z);
    this.scene.add(this.grid);
  }

  // Looks at `box` from behind-left and above, the whole box in view.
  frame(box) {
    const c = box.getCenter(new THREE.Vector3());
    const r = Math.max(1, box.getSize(new THREE.Vector3()).length() / 2);
    this.controls.target.copy(c);
    this.camera.position.set(c.x - 0.85 * r, c.y - 0.65 * r, c.z + 0.75 * r);
    this.controls.update();
  }

  start(beforeRender) {
    const loop = () => {
      beforeRender();
      this.renderer.render(this.scene, this.camera);
      this.labels.render(this.scene, this.camera);
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  // The first of `objects` under client pixel (x, y), or null.
  pick(x, y, objects) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((x - rect.left) / rect.width) * 2 - 1,
                                  -((y - rect.top) / rect.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, this.camera);
    const hits = ray.intersectObjects(objects, false);
    return hits.length ? hits[0].object : null;
  }

  // Client pixel of a map-frame point, or null when behind the camera.
  toClient(p) {
    const v = new THREE.Vector3(p.x, p.y, p.z).project(this.camera);
    if (v.z > 1) return null;
    const rect = this.renderer.domElement.getBoundingClientRect();
    return { x: rect.left + (v.x + 1) / 2 * rect.width, y: rect.top + (1 - v.y) / 2 * rect.height };
  }
}
