// Entry of the three.js bundle the HTML report's viewer loads as a classic script (window.THREE):
// Chromium does not load ES modules from file:// pages, and a report must open from the file system.
export * from 'three';
export { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
