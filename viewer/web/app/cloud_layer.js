// The semantic cloud (GET api/cloud): one point per voxel, coloured by its object's class or by
// its RGB.
import * as THREE from './three_modules.js';
import { BACKGROUND, classColour, rgbFloats } from './colors.js';

export class CloudLayer {
  constructor(scene) {
    this.geometry = new THREE.BufferGeometry();
    this.material = new THREE.PointsMaterial({ size: 0.04, vertexColors: THREE.VertexColors });
    this.points = new THREE.Points(this.geometry, this.material);
    this.points.raycast = () => {};  // clicks select objects, not cloud points
    scene.add(this.points);
    this.mode = 'label';
    this.rgb = new Float32Array(0);
    this.objectIds = [];
    this.count = 0;
  }

  // `cloud`: a GetCloudResponse; `voxelM` the size it was sampled at.
  set(cloud, voxelM) {
    const pts = cloud.points || [];
    const xyz = new Float32Array(pts.length * 3);
    this.rgb = new Float32Array(pts.length * 3);
    this.objectIds = new Array(pts.length);
    pts.forEach((p, i) => {
      xyz.set([p.xM, p.yM, p.zM], 3 * i);
      this.rgb.set(rgbFloats(p.rgb), 3 * i);
      this.objectIds[i] = Number(p.objectId);
    });
    this.geometry.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    this.geometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(xyz.length), 3));
    this.material.size = Math.max(0.02, voxelM);
    this.count = pts.length;
  }

  // Recolours by `mode` ('label' or 'rgb'); `classOf(id)` names an object's class.
  colour(mode, classOf) {
    this.mode = mode;
    const attr = this.geometry.getAttribute('color');
    if (!attr) return;
    if (mode === 'rgb') {
      attr.array.set(this.rgb);
    } else {
      const c = new THREE.Color();
      this.objectIds.forEach((id, i) => {
        const cls = id ? classOf(id) : null;
        c.setHex(cls ? classColour(cls) : BACKGROUND);
        if (!cls) c.multiplyScalar(0.55);
        attr.array.set([c.r, c.g, c.b], 3 * i);
      });
    }
    attr.needsUpdate = true;
  }

  // Bounds of the bulk of the cloud: the 2nd to 98th percentile on each axis (stray points
  // ignored); the floor is its bottom.
  bounds() {
    if (this.count === 0) return null;
    const pos = this.geometry.getAttribute('position').array;
    const step = 3 * Math.max(1, Math.floor(this.count / 5000));
    const lo = new THREE.Vector3(), hi = new THREE.Vector3();
    for (let axis = 0; axis < 3; ++axis) {
      const v = [];
      for (let i = axis; i < pos.length; i += step) v.push(pos[i]);
      v.sort((a, b) => a - b);
      lo.setComponent(axis, v[Math.floor(0.02 * (v.length - 1))]);
      hi.setComponent(axis, v[Math.ceil(0.98 * (v.length - 1))]);
    }
    return new THREE.Box3(lo, hi);
  }
}
