// biped replay viewer: plays a biped.viz.Replay (embedded as JSON) with three.js.
// Part of biped (MIT). Strings from the data reach the page through textContent only.

const $ = (id) => document.getElementById(id);

// Content-Security-Policy (default-src 'none') blocks any network access; record attempts.
const violations = [];
document.addEventListener("securitypolicyviolation", (e) => violations.push(e.blockedURI + " " + e.violatedDirective));

function showMessage(text) {
  const m = $("message");
  m.textContent = text;
  m.style.display = "block";
}

function moduleURL(text) {
  return URL.createObjectURL(new Blob([text], { type: "text/javascript" }));
}

// The vendored three.js module build imports "./three.core.min.js" and OrbitControls imports
// "three": point both at in-page blob URLs instead, so nothing is fetched.
async function loadThree() {
  const core = moduleURL($("three-core").textContent);
  const mod = moduleURL($("three-module").textContent
    .split('"./three.core.min.js"').join(JSON.stringify(core)));
  const orbit = moduleURL($("orbit-controls").textContent
    .replace(/from\s*['"]three['"]/g, "from " + JSON.stringify(mod)));
  const THREE = await import(mod);
  const { OrbitControls } = await import(orbit);
  return { THREE, OrbitControls };
}

function f32(b64) {
  const bin = atob(b64);
  const u8 = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
  return new Float32Array(u8.buffer);
}

function u32(b64) {
  const bin = atob(b64);
  const u8 = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
  return new Uint32Array(u8.buffer);
}

function hashParams() {
  const out = {};
  for (const kv of location.hash.replace(/^#/, "").split("&")) {
    const [k, v] = kv.split("=");
    if (k) out[decodeURIComponent(k)] = decodeURIComponent(v || "");
  }
  return out;
}

async function main() {
  const D = JSON.parse($("replay-data").textContent);
  const T = D.T, G = D.G, t0 = D.t0;
  const times = f32(D.times), P = f32(D.pos), Q = f32(D.quat);
  const tEnd = times[T - 1];

  // ---- overlay (text only) ----
  $("title").textContent = D.title;
  const info = $("info");
  for (const [k, v] of D.info) {
    const tr = info.insertRow();
    tr.insertCell().textContent = k;
    const c = tr.insertCell();
    c.textContent = v;
    c.className = "v";
  }
  $("toggle-overlay").addEventListener("click", () => {
    const b = $("overlay-body");
    const hidden = b.style.display === "none";
    b.style.display = hidden ? "" : "none";
    $("toggle-overlay").textContent = hidden ? "\u2212" : "+";
  });

  const { THREE, OrbitControls } = await loadThree();
  THREE.Object3D.DEFAULT_UP.set(0, 0, 1);

  // ---- renderer, scene, camera ----
  const view = $("view");
  let renderer;
  try {
    renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  } catch (err) {
    showMessage("This replay needs WebGL, which this browser could not start: " + err.message);
    document.body.dataset.ready = "error";
    return;
  }
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(window.innerWidth, window.innerHeight);
  renderer.shadowMap.enabled = true;
  renderer.shadowMap.type = THREE.PCFShadowMap;
  view.appendChild(renderer.domElement);

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xe9edf1);
  scene.fog = new THREE.Fog(0xe9edf1, 12, 60);
  const camera = new THREE.PerspectiveCamera(40, window.innerWidth / window.innerHeight, 0.02, 500);
  camera.up.set(0, 0, 1);

  scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8f96, 1.6));
  const sun = new THREE.DirectionalLight(0xffffff, 1.8);
  sun.castShadow = true;
  sun.shadow.mapSize.set(1024, 1024);
  Object.assign(sun.shadow.camera, { left: -3, right: 3, top: 3, bottom: -3, near: 0.1, far: 30 });
  sun.shadow.bias = -0.0005;
  scene.add(sun, sun.target);
  const sunOffset = new THREE.Vector3(2.5, -3.0, 6.0);

  // ---- geoms ----
  const meshes = [];
  let hasPlane = false;
  const shapes = (D.meshes || []).map((m) => {  // a robot's meshes: vertices in the geom's frame
    const geo = new THREE.BufferGeometry();
    geo.setAttribute("position", new THREE.BufferAttribute(f32(m.verts), 3));
    geo.setIndex(new THREE.BufferAttribute(u32(m.faces), 1));
    geo.computeVertexNormals();
    return geo;
  });
  for (const g of D.geoms) {
    const s = g.size;
    let geo;
    switch (g.kind) {
      case "box": geo = new THREE.BoxGeometry(2 * s[0], 2 * s[1], 2 * s[2]); break;
      case "sphere": geo = new THREE.SphereGeometry(s[0], 32, 16); break;
      case "ellipsoid": geo = new THREE.SphereGeometry(1, 32, 16); geo.scale(s[0], s[1], s[2]); break;
      case "capsule": geo = new THREE.CapsuleGeometry(s[0], 2 * s[1], 8, 24); geo.rotateX(Math.PI / 2); break;
      case "cylinder": geo = new THREE.CylinderGeometry(s[0], s[0], 2 * s[1], 24); geo.rotateX(Math.PI / 2); break;
      case "plane": geo = new THREE.PlaneGeometry(2 * (s[0] || 10), 2 * (s[1] || 10)); hasPlane = true; break;
      case "mesh": geo = shapes[g.mesh]; break;
      default: geo = new THREE.BoxGeometry(0.02, 0.02, 0.02);
    }
    const [r, gg, b, a] = g.rgba;
    const mat = new THREE.MeshStandardMaterial({
      color: new THREE.Color().setRGB(r, gg, b, THREE.SRGBColorSpace),
      roughness: 0.75, metalness: 0.0, transparent: a < 1, opacity: a,
    });
    if (g.kind === "plane") { mat.polygonOffset = true; mat.polygonOffsetFactor = 1; mat.polygonOffsetUnits = 1; }
    const mesh = new THREE.Mesh(geo, mat);
    mesh.name = g.name;
    mesh.castShadow = g.kind !== "plane";
    mesh.receiveShadow = true;
    mesh.matrixAutoUpdate = true;
    scene.add(mesh);
    meshes.push(mesh);
  }

  // bounds of the motion (non-plane geoms) for the floor, the grid and the first view
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  const lo0 = [Infinity, Infinity, Infinity], hi0 = [-Infinity, -Infinity, -Infinity];
  for (let g = 0; g < G; g++) {
    if (D.geoms[g].kind === "plane") continue;
    for (let t = 0; t < T; t++) {
      for (let i = 0; i < 3; i++) {
        const v = P[(t * G + g) * 3 + i];
        if (v < lo[i]) lo[i] = v;
        if (v > hi[i]) hi[i] = v;
        if (t === 0) { if (v < lo0[i]) lo0[i] = v; if (v > hi0[i]) hi0[i] = v; }
      }
    }
  }
  if (!isFinite(lo[0])) { lo.fill(-1); hi.fill(1); lo0.fill(-1); hi0.fill(1); }

  // floor and grid at z = 0
  const half = Math.max(2, Math.ceil(Math.max(hi[0] - lo[0], hi[1] - lo[1]) / 2 + 1.5));
  const cx = Math.round((lo[0] + hi[0]) / 2), cy = Math.round((lo[1] + hi[1]) / 2);
  if (!hasPlane) {
    const floor = new THREE.Mesh(new THREE.PlaneGeometry(200, 200),
      new THREE.MeshStandardMaterial({ color: 0xd5d9de, roughness: 1, polygonOffset: true,
        polygonOffsetFactor: 1, polygonOffsetUnits: 1 }));
    floor.position.set(cx, cy, 0);
    floor.receiveShadow = true;
    scene.add(floor);
  }
  for (const [step, color, opacity] of [[0.1, 0x9aa3ad, 0.35], [1.0, 0x5f6a75, 0.7]]) {
    const n = Math.round(2 * half / step);
    const grid = new THREE.GridHelper(2 * half, n, color, color);
    grid.rotation.x = Math.PI / 2;
    grid.position.set(cx, cy, 0.0005);
    grid.material.transparent = true;
    grid.material.opacity = opacity;
    grid.material.depthWrite = false;
    scene.add(grid);
  }

  // ---- camera control ----
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.enableDamping = false;
  controls.maxPolarAngle = Math.PI * 0.495;
  const follow = D.follow;   // index of the geom the camera follows, or -1
  const followAt = (t) => new THREE.Vector3().fromArray(P, (t * G + follow) * 3);
  const height0 = Math.max(hi0[2] - lo0[2], hi0[0] - lo0[0], hi0[1] - lo0[1], 0.5);
  const home = new THREE.Vector3((lo0[0] + hi0[0]) / 2, (lo0[1] + hi0[1]) / 2, (lo0[2] + hi0[2]) / 2);
  let followRef = follow >= 0 ? followAt(0) : null;   // where the followed geom was when the view was set
  function resetView() {
    const target = home.clone();
    if (follow >= 0) {   // keep the view of frame 0, shifted with the followed geom
      const p = meshes[follow].position.clone();
      target.add(p.clone().sub(followAt(0)));
      followRef = p;
    }
    const dir = new THREE.Vector3(-0.55, -1.0, 0.32).normalize();
    controls.target.copy(target);
    camera.position.copy(target).addScaledVector(dir, 2.4 * height0 + 0.6);
    controls.update();
    requestRender();
  }

  // ---- playback ----
  let now = 0, playing = false, speed = 1, currentIndex = 0, lastWall = null, dirty = true;
  const qa = new THREE.Quaternion(), qb = new THREE.Quaternion();
  const scrub = $("scrub");
  scrub.max = String(tEnd > 0 ? tEnd : 1);

  function indexAt(t) {   // last k with times[k] <= t
    let a = 0, b = T - 1;
    if (t >= times[b]) return b;
    while (b - a > 1) { const m = (a + b) >> 1; if (times[m] <= t) a = m; else b = m; }
    return a;
  }

  function pose(t) {
    const k = indexAt(t), k1 = Math.min(k + 1, T - 1);
    const span = times[k1] - times[k];
    const w = span > 0 ? Math.min(Math.max((t - times[k]) / span, 0), 1) : 0;
    currentIndex = w < 0.5 ? k : k1;
    for (let g = 0; g < G; g++) {
      const i = (k * G + g), j = (k1 * G + g);
      const m = meshes[g];
      m.position.set(
        P[3 * i] + w * (P[3 * j] - P[3 * i]),
        P[3 * i + 1] + w * (P[3 * j + 1] - P[3 * i + 1]),
        P[3 * i + 2] + w * (P[3 * j + 2] - P[3 * i + 2]));
      qa.set(Q[4 * i + 1], Q[4 * i + 2], Q[4 * i + 3], Q[4 * i]);   // (w,x,y,z) -> three's (x,y,z,w)
      qb.set(Q[4 * j + 1], Q[4 * j + 2], Q[4 * j + 3], Q[4 * j]);
      m.quaternion.slerpQuaternions(qa, qb, w);
    }
    if (follow >= 0 && $("follow").checked) {
      const p = meshes[follow].position;
      const d = new THREE.Vector3().subVectors(p, followRef);
      controls.target.add(d);
      camera.position.add(d);
      followRef = p.clone();
    } else if (follow >= 0) {
      followRef = meshes[follow].position.clone();
    }
    sun.target.position.copy(controls.target);
    sun.position.copy(controls.target).add(sunOffset);
  }

  // markers on the timeline and in the overlay
  const markers = D.markers.map((m) => ({ t: m.t - t0, label: m.label }));
  const ticks = $("ticks"), events = $("events");
  if (!markers.length) $("events-head").style.display = "none";
  const rows = [];
  for (const m of markers) {
    const frac = tEnd > 0 ? Math.min(Math.max(m.t / tEnd, 0), 1) : 0;
    const tick = document.createElement("span");
    tick.style.left = (100 * frac).toFixed(3) + "%";
    tick.title = (m.t + t0).toFixed(3) + " s  " + m.label;
    tick.addEventListener("click", () => seek(m.t));
    ticks.appendChild(tick);
    const row = document.createElement("div");
    row.textContent = (m.t + t0).toFixed(3) + " s  " + m.label;
    row.addEventListener("click", () => seek(m.t));
    events.appendChild(row);
    rows.push(row);
  }

  function updateUI() {
    $("clock").textContent = "t = " + (now + t0).toFixed(3) + " s";
    scrub.value = String(now);
    $("play").innerHTML = playing ? "&#x275A;&#x275A;" : "&#x25B6;";
    let last = null;
    markers.forEach((m, i) => {
      const past = m.t <= now + 1e-9;
      rows[i].className = past ? "past" : "";
      if (past && now - m.t < 0.3) last = m;
    });
    const en = $("event-now");
    if (last) { en.textContent = (last.t + t0).toFixed(3) + " s  " + last.label; en.style.display = "block"; }
    else en.style.display = "none";
  }

  function requestRender() { dirty = true; }
  function seek(t) { now = Math.min(Math.max(t, 0), tEnd); pose(now); updateUI(); requestRender(); }
  function setPlaying(p) {
    if (p && now >= tEnd) now = 0;
    playing = p && tEnd > 0;
    lastWall = null;
    updateUI();
  }
  function stepFrame(dir) {
    setPlaying(false);
    const k = indexAt(now + 1e-9);
    seek(times[Math.min(Math.max(k + dir, 0), T - 1)]);
  }

  $("play").addEventListener("click", () => setPlaying(!playing));
  scrub.addEventListener("input", () => { setPlaying(false); seek(parseFloat(scrub.value)); });
  $("speed").addEventListener("change", (e) => { speed = parseFloat(e.target.value); });
  $("reset").addEventListener("click", resetView);
  $("follow").addEventListener("change", () => { if (follow >= 0) followRef = meshes[follow].position.clone(); });
  controls.addEventListener("change", requestRender);
  window.addEventListener("keydown", (e) => {
    if (e.target instanceof HTMLSelectElement) return;
    if (e.code === "Space") { e.preventDefault(); setPlaying(!playing); }
    else if (e.code === "ArrowRight") stepFrame(+1);
    else if (e.code === "ArrowLeft") stepFrame(-1);
    else if (e.code === "Home") { setPlaying(false); seek(0); }
  });
  window.addEventListener("resize", () => {
    camera.aspect = window.innerWidth / window.innerHeight;
    camera.updateProjectionMatrix();
    renderer.setSize(window.innerWidth, window.innerHeight);
    requestRender();
  });

  function frame(wall) {
    if (playing) {
      if (lastWall !== null) {
        now += speed * (wall - lastWall) / 1000;
        if (now >= tEnd) {
          if ($("loop").checked) now = now % tEnd;
          else { now = tEnd; playing = false; }
        }
        pose(now);
        updateUI();
        dirty = true;
      }
      lastWall = wall;
    }
    if (dirty) { renderer.render(scene, camera); dirty = false; }
    requestAnimationFrame(frame);
  }

  // start: #t=<seconds>&play=1 in the address pick the first frame and autoplay
  const hp = hashParams();
  const start = hp.t !== undefined && isFinite(parseFloat(hp.t)) ? parseFloat(hp.t) - t0 : 0;
  now = Math.min(Math.max(start, 0), tEnd);
  pose(now);
  resetView();
  updateUI();
  renderer.render(scene, camera);
  dirty = false;
  if (hp.play === "1") setPlaying(true);
  requestAnimationFrame(frame);
  if (hp.probe === "1") probe(THREE, meshes);
  document.body.dataset.ready = "1";
}

// #probe=1: write what was drawn as JSON into a hidden pre element (id "probe"), for tests (chromium --dump-dom):
// each mesh's world axis-aligned bounding box at the shown time, resources loaded and blocked.
function probe(THREE, meshes) {
  const boxes = meshes.map((m) => {
    m.updateWorldMatrix(true, false);
    const b = new THREE.Box3().setFromObject(m, true);
    return { name: m.name, min: b.min.toArray(), max: b.max.toArray() };
  });
  const out = document.createElement("pre");
  out.id = "probe";
  out.style.display = "none";
  out.textContent = JSON.stringify({
    boxes, violations,
    resources: performance.getEntriesByType("resource").map((e) => e.name),
    title: document.title, h1: $("title").textContent, hash: location.hash,
  });
  document.body.appendChild(out);
}

main().catch((err) => {
  showMessage("The replay could not start: " + (err && err.message ? err.message : String(err)));
  document.body.dataset.ready = "error";
});
