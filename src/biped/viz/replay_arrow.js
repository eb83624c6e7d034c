// biped replay viewer, the perturbation's arrow (a push while it acts, a tether while it holds).
// biped.viz.replay.write_replay appends this to replay_viewer.js, and hooks it in, only when the
// replay has an arrow. Part of biped (MIT).

// A red arrow (unlit, the video's colour) and showArrow(k, k1, w): frame k's arrow (tail, tip),
// moved toward frame k1's by w when both have one; hidden where frame k has none (NaN).
function makeArrow(THREE, scene, A) {
  const tail = f32(A.tail), tip = f32(A.tip);
  const [r, g, b] = A.rgba;
  const mat = new THREE.MeshBasicMaterial({ color: new THREE.Color().setRGB(r, g, b, THREE.SRGBColorSpace), fog: false });
  const shaft = new THREE.Mesh(new THREE.CylinderGeometry(1, 1, 1, 16), mat);   // unit, along +y
  const head = new THREE.Mesh(new THREE.ConeGeometry(1, 1, 24), mat);
  const arrow = new THREE.Group();
  arrow.name = "arrow";
  arrow.add(shaft, head);
  arrow.visible = false;
  scene.add(arrow);
  const a = new THREE.Vector3(), c = new THREE.Vector3(), d = new THREE.Vector3(), e = new THREE.Vector3();
  const yAxis = new THREE.Vector3(0, 1, 0);
  const has = (k) => isFinite(tail[3 * k]) && isFinite(tip[3 * k]);
  return function showArrow(k, k1, w) {
    if (!has(k)) { arrow.visible = false; return; }
    a.fromArray(tail, 3 * k); c.fromArray(tip, 3 * k);
    if (k1 !== k && has(k1)) { a.lerp(d.fromArray(tail, 3 * k1), w); c.lerp(e.fromArray(tip, 3 * k1), w); }
    d.subVectors(c, a);
    const L = d.length();
    if (!(L > 1e-6)) { arrow.visible = false; return; }
    const hl = Math.min(0.3 * L, 0.1), hr = 0.04, sr = 0.016;
    shaft.scale.set(sr, L - hl, sr);
    shaft.position.set(0, (L - hl) / 2, 0);
    head.scale.set(hr, hl, hr);
    head.position.set(0, L - hl / 2, 0);
    arrow.position.copy(a);
    arrow.quaternion.setFromUnitVectors(yAxis, d.divideScalar(L));
    arrow.visible = true;
  };
}
