"""The self-contained HTML page of an animation: three.js (vendored, inlined as an ES module through an import
map), the run's data as JSON, and a small viewer (play/pause, time slider, speed) with no other file or network
access. `#t=1.2` in the address opens the page paused at that time (used for screenshots and links).
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

from mbs.base.atomic import write_text_atomic

VENDOR = Path(__file__).resolve().parent / "vendor" / "three"

VIEWER_JS = r"""
import * as THREE from "three";
const status = (s) => { document.body.dataset.status = s; };
window.addEventListener("error", (e) => status("error: " + e.message));
const data = JSON.parse(document.getElementById("mbs-data").textContent);
const t = data.t, n = t.length;
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setSize(window.innerWidth, window.innerHeight);
document.body.prepend(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xeef1f5);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
sun.position.set(3, -5, 8);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(35, window.innerWidth / window.innerHeight, 0.01, 2000);
camera.up.set(0, 0, 1);

// parts: the equivalent inertia box at the centre of mass, links to the frames, wheels as discs
const palette = [0x3b6ea5, 0xd08c2b, 0x5a9a5a, 0xa04b4b, 0x7b5ea7, 0x3d8f8f, 0x8c6d46, 0x6f7f8f];
const groups = data.bodies.map((b, i) => {
  const g = new THREE.Group();
  const color = palette[i % palette.length];
  // see-through boxes: the links and wheels inside a car body stay visible
  const solid = new THREE.MeshStandardMaterial({ color, roughness: 0.6, metalness: 0.1, transparent: true,
                                                 opacity: 0.45, depthWrite: false });
  const com = new THREE.Vector3(...b.com);
  if (b.wheel_radius) {
    const wheel = new THREE.Mesh(new THREE.CylinderGeometry(b.wheel_radius, b.wheel_radius, 0.22, 40),
                                 new THREE.MeshStandardMaterial({ color: 0x2b2b2b, roughness: 0.9 }));
    wheel.position.copy(com);
    g.add(wheel);
    const hub = new THREE.Mesh(new THREE.CylinderGeometry(0.4 * b.wheel_radius, 0.4 * b.wheel_radius, 0.24, 6),
                               new THREE.MeshStandardMaterial({ color: 0xb0b0b0 }));
    hub.position.copy(com);
    g.add(hub);  // six-sided: the spin shows
  } else {
    const box = new THREE.Mesh(new THREE.BoxGeometry(...b.box), solid);
    box.position.copy(com);
    g.add(box);
  }
  const link = new THREE.MeshStandardMaterial({ color, roughness: 0.4 });
  for (const f of b.frames) {
    const p = new THREE.Vector3(...f), d = p.clone().sub(com), len = d.length();
    const ball = new THREE.Mesh(new THREE.SphereGeometry(0.018, 12, 8), link);
    ball.position.copy(p);
    g.add(ball);
    if (len > 1e-6) {
      const rod = new THREE.Mesh(new THREE.CylinderGeometry(0.008, 0.008, len, 8), link);
      rod.position.copy(com.clone().add(p).multiplyScalar(0.5));
      rod.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), d.normalize());
      g.add(rod);
    }
  }
  scene.add(g);
  return g;
});

// roads: a ribbon along each tyre's track (static, or one profile per frame when the road moves)
const roads = data.roads.map((r) => {
  const m = r.x.length, pos = new Float32Array(6 * m), index = [];
  for (let k = 0; k + 1 < m; k++) index.push(2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 1, 2 * k + 3, 2 * k + 2);
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute("position", new THREE.BufferAttribute(pos, 3));
  geometry.setIndex(index);
  const mesh = new THREE.Mesh(geometry, new THREE.MeshStandardMaterial({ color: 0x777770, side: THREE.DoubleSide }));
  scene.add(mesh);
  return { r, pos, geometry };
});
function setRoads(i) {
  for (const { r, pos, geometry } of roads) {
    const z = r.moving ? r.z[i] : r.z;
    for (let k = 0; k < r.x.length; k++) {
      pos.set([r.x[k], r.y - 0.18, z[k], r.x[k], r.y + 0.18, z[k]], 6 * k);
    }
    geometry.attributes.position.needsUpdate = true;
    geometry.computeVertexNormals();
  }
}

// the camera follows the heaviest part sideways and along, at a distance from the size of the mechanism
function pose(g, b, i) {
  const p = b.poses[i];
  g.position.set(p[0], p[1], p[2]);
  g.quaternion.set(p[3], p[4], p[5], p[6]);
}
data.bodies.forEach((b, k) => pose(groups[k], b, 0));
scene.updateMatrixWorld(true);
const bounds = new THREE.Box3();
groups.forEach((g) => bounds.expandByObject(g));
const centre = bounds.getCenter(new THREE.Vector3()), size = Math.max(bounds.getSize(new THREE.Vector3()).length(), 1);
const grid = new THREE.GridHelper(40 * size, 80, 0x99a0aa, 0xc8ccd2);
grid.rotation.x = Math.PI / 2;
grid.position.z = Math.min(0, bounds.min.z) - 1e-3;
scene.add(grid);
let heaviest = 0;
data.bodies.forEach((b, k) => { if (b.mass > data.bodies[heaviest].mass) heaviest = k; });
const start = new THREE.Vector3(...data.bodies[heaviest].poses[0].slice(0, 2), 0);
const offset = new THREE.Vector3(0.55, -1.6, 0.6).multiplyScalar(1.3 * size);

const slider = document.getElementById("slider"), label = document.getElementById("time");
const play = document.getElementById("play"), speed = document.getElementById("speed");
slider.max = n - 1;
let playing = true, time = t[0], last = null;
function frameAt(s) {
  let lo = 0, hi = n - 1;
  while (lo < hi) { const mid = (lo + hi + 1) >> 1; if (t[mid] <= s) lo = mid; else hi = mid - 1; }
  return lo;
}
function draw(i) {
  data.bodies.forEach((b, k) => pose(groups[k], b, i));
  setRoads(i);
  const p = data.bodies[heaviest].poses[i];
  const target = centre.clone().add(new THREE.Vector3(p[0] - start.x, p[1] - start.y, 0));
  camera.position.copy(target).add(offset);
  camera.lookAt(target);
  slider.value = i;
  label.textContent = `t = ${t[i].toFixed(3)} s`;
  renderer.render(scene, camera);
}
function tick(now) {
  if (playing && last !== null) {
    time += (now - last) / 1000 * parseFloat(speed.value);
    if (time > t[n - 1]) time = t[0];
  }
  last = now;
  draw(frameAt(time));
  requestAnimationFrame(tick);
}
play.onclick = () => { playing = !playing; play.textContent = playing ? "pause" : "play"; };
slider.oninput = () => { time = t[+slider.value]; };
window.addEventListener("resize", () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
});
const wanted = /t=([-+0-9.eE]+)/.exec(location.hash);
if (wanted) { playing = false; play.textContent = "play"; time = parseFloat(wanted[1]); }
draw(frameAt(time));
status("ready");
requestAnimationFrame(tick);
"""

PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<!-- three.js {version} (MIT licence, three.js authors), inlined unchanged -->
<script type="importmap">{{"imports": {{"three": "data:text/javascript;base64,{three}"}}}}</script>
<style>
body {{ margin: 0; overflow: hidden; font: 14px system-ui, sans-serif; }}
#bar {{ position: absolute; left: 0; right: 0; bottom: 0; display: flex; gap: 10px; align-items: center;
        padding: 8px 12px; background: rgba(255, 255, 255, 0.85); }}
#slider {{ flex: 1; }}
#title {{ position: absolute; left: 12px; top: 8px; color: #333; }}
</style>
</head>
<body data-status="loading">
<div id="title">{title}</div>
<div id="bar"><button id="play">pause</button><input id="slider" type="range" min="0" value="0">
<span id="time"></span><label>speed <select id="speed"><option>0.1</option><option>0.25</option>
<option>0.5</option><option selected>1</option><option>2</option></select></label></div>
<script id="mbs-data" type="application/json">{data}</script>
<script type="module">{viewer}</script>
</body>
</html>
"""


def page(animation) -> str:
    """The HTML text (three.js and the data inline: the page needs no other file)."""
    from html import escape
    three = (VENDOR / "three.module.min.js").read_bytes()
    data = json.dumps(animation.to_json(), separators=(",", ":")).replace("</", "<\\/")
    return PAGE.format(title=escape(animation.title), version="0.170.0", three=base64.b64encode(three).decode(),
                       data=data, viewer=VIEWER_JS)


def write_page(animation, path) -> Path:
    write_text_atomic(path, page(animation))
    return Path(path)
