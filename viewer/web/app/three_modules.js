// The three.js modules the viewer uses: Debian's libjs-three (r111), copied into lib/ at build
// time (viewer/CMakeLists.txt).
export * from '../lib/three/build/three.module.js';
export { OrbitControls } from '../lib/three/examples/jsm/controls/OrbitControls.js';
export { CSS2DRenderer, CSS2DObject } from '../lib/three/examples/jsm/renderers/CSS2DRenderer.js';
