// Each robot's keyframe trajectory (GET api/trajectories, T_map_cam per keyframe) as a line in
// its own colour, and its latest pose as an arrow along the camera's viewing axis (optical z).
import * as THREE from './three_modules.js';
import { cssColour, robotColour } from './colors.js';

export class RobotLayer {
  constructor(scene) {
    this.group = new THREE.Group();
    scene.add(this.group);
    this.robots = new Map();  // name -> {line, arrow, label, poses}
  }

  // `trajectories`: GetTrajectoriesResponse.trajectories.
  set(trajectories) {
    const names = trajectories.map((t) => t.robot).sort();
    for (const name of [...this.robots.keys()]) {
      if (!names.includes(name)) this.drop(name);
    }
    for (const t of trajectories) {
      const known = this.robots.get(t.robot);
      if (known && known.poses === t.poses.length) continue;
      this.drop(t.robot);
      this.add(t, robotColour(names.indexOf(t.robot)));
    }
  }

  add(t, colour) {
    const pts = t.poses.map((p) => new THREE.Vector3(p.TMapCam.tM.x, p.TMapCam.tM.y, p.TMapCam.tM.z));
    if (pts.length === 0) return;
    const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(pts),
                                new THREE.LineBasicMaterial({ color: colour }));
    const last = t.poses[t.poses.length - 1].TMapCam;
    const q = new THREE.Quaternion(last.qx, last.qy, last.qz, last.qw);
    const forward = new THREE.Vector3(0, 0, 1).applyQuaternion(q);
    const arrow = new THREE.ArrowHelper(forward, pts[pts.length - 1], 0.35, colour, 0.12, 0.08);
    const div = document.createElement('div');
    div.className = 'robot-label';
    div.style.color = cssColour(colour);
    div.textContent = t.robot;
    const label = new THREE.CSS2DObject(div);
    label.position.copy(pts[pts.length - 1]).add(new THREE.Vector3(0, 0, 0.15));
    this.group.add(line, arrow, label);
    this.robots.set(t.robot, { line, arrow, label, poses: t.poses.length,
                               latest: pts[pts.length - 1].toArray(), colour });
  }

  drop(name) {
    const r = this.robots.get(name);
    if (!r) return;
    this.group.remove(r.line, r.arrow, r.label);
    r.label.element.remove();
    r.line.geometry.dispose();
    r.line.material.dispose();
    this.robots.delete(name);
  }

  // [{robot, poses, latest: [x, y, z], colour}] for the page state.
  summary() {
    return [...this.robots.entries()].map(([robot, r]) => ({
      robot, poses: r.poses, latest: r.latest, colour: cssColour(r.colour) }));
  }
}
