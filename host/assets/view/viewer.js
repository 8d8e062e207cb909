// omcbsa plan viewer. Everything it draws comes from the embedded scene, computed by the host
// with the planner's own kinematic model: link frames per step, joint axes, capsules, poses.
// three.js is loaded from the page itself (no network); see the licences in the page.
(async function () {
  "use strict";
  const view = (window.omcbsaView = { ready: false, error: null });
  const text = (id) => document.getElementById(id).textContent;
  try {
    // The libraries and meshes are in the page, or in a shared script (`omcbsa bench` pages).
    const assets = window.omcbsaAssets || JSON.parse(text("assets"));
    const moduleUrl = (src) => URL.createObjectURL(new Blob([src], { type: "text/javascript" }));
    const threeUrl = moduleUrl(assets.three);
    const THREE = await import(threeUrl);
    const orbit = assets.orbit.replace("from 'three'", "from '" + threeUrl + "'");
    const { OrbitControls } = await import(moduleUrl(orbit));
    start(THREE, OrbitControls, JSON.parse(text("data")), assets.meshes, view);
  } catch (e) {
    view.error = String(e && e.stack ? e.stack : e);
    document.getElementById("status").innerHTML = '<span class="bad">The viewer failed: ' +
      String(e).replace(/</g, "&lt;") + "</span>";
    throw e;
  }
})();

function start(THREE, OrbitControls, data, meshes, view) {
  "use strict";
  const COLORS = [0x1f77b4, 0xff7f0e, 0x2ca02c, 0x9467bd, 0x8c564b, 0xe377c2, 0x17becf, 0xbcbd22];
  const CLASH = 0xe0141e;
  const hex = (c) => "#" + c.toString(16).padStart(6, "0");
  const el = (id) => document.getElementById(id);
  const escape = (s) => String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;");

  // ---- renderer, camera, lights (world z is up, as in the problem files)
  const box = el("view");
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  box.appendChild(renderer.domElement);
  const world = new THREE.Scene();
  world.background = new THREE.Color(0xf4f5f7);
  const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 100);
  camera.up.set(0, 0, 1);
  world.add(new THREE.HemisphereLight(0xffffff, 0x8890a0, 2.0));
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  sun.position.set(2, -3, 5);
  world.add(sun);
  const grid = new THREE.GridHelper(4, 40, 0xb0b4bc, 0xd4d7dd);
  grid.rotation.x = Math.PI / 2;
  world.add(grid);

  // ---- the models' meshes (binary STL)
  function stlGeometry(b64) {
    const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
    const dv = new DataView(bytes.buffer);
    const n = dv.getUint32(80, true);
    const pos = new Float32Array(n * 9), nrm = new Float32Array(n * 9);
    for (let i = 0; i < n; i++) {
      const o = 84 + 50 * i;
      for (let v = 0; v < 3; v++) {
        for (let k = 0; k < 3; k++) {
          nrm[9 * i + 3 * v + k] = dv.getFloat32(o + 4 * k, true);
          pos[9 * i + 3 * v + k] = dv.getFloat32(o + 12 + 12 * v + 4 * k, true);
        }
      }
    }
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(pos, 3));
    g.setAttribute("normal", new THREE.BufferAttribute(nrm, 3));
    return g;
  }
  const geometries = {};
  for (const model of Object.keys(meshes)) {
    geometries[model] = {};
    for (const link of Object.keys(meshes[model])) geometries[model][link] = stlGeometry(meshes[model][link]);
  }

  // A capsule (or cylinder) between local points a and b; three's shapes run along y.
  function between(geometry, material, a, b) {
    const va = new THREE.Vector3(...a), vb = new THREE.Vector3(...b);
    const m = new THREE.Mesh(geometry, material);
    m.position.copy(va).add(vb).multiplyScalar(0.5);
    const d = vb.clone().sub(va);
    if (d.length() > 1e-9) m.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), d.normalize());
    return m;
  }
  const capsuleGeometry = (r, a, b) =>
    new THREE.CapsuleGeometry(r, new THREE.Vector3(...a).distanceTo(new THREE.Vector3(...b)), 6, 16);

  // ---- arms: one group per robot, one object per link placed at the embedded frames
  const capsuleObjects = [];
  const arms = data.robots.map((robot, i) => {
    const color = COLORS[i % COLORS.length];
    const group = new THREE.Group();
    group.name = "arm";
    group.userData.robot = i;
    const model = data.models[robot.model];
    const shapes = geometries[model.name] || {};
    const links = model.links.map((name, l) => {
      const link = new THREE.Group();
      link.name = name;
      link.matrixAutoUpdate = false;
      const material = new THREE.MeshStandardMaterial({ color, roughness: 0.55, metalness: 0.1 });
      if (shapes[name]) link.add(new THREE.Mesh(shapes[name], material));
      link.userData.material = material;
      link.userData.color = color;
      const capsuleMaterial = new THREE.MeshStandardMaterial({ color, transparent: true, opacity: 0.45 });
      for (const c of model.capsules.filter((c) => c.link === l)) {
        const m = between(capsuleGeometry(c.radius, c.a, c.b), capsuleMaterial, c.a, c.b);
        // A model without meshes is drawn as its capsules.
        m.userData.always = !geometries[model.name];
        m.visible = m.userData.always;
        capsuleObjects.push(m);
        link.add(m);
      }
      group.add(link);
      return link;
    });
    world.add(group);
    return { robot, links, joints: model.joints };
  });

  // ---- trajectories in their arm's colour, and the target pose of the current step
  const targets = data.trajectories.map((t) => {
    const color = t.robot === null ? 0x777777 : COLORS[t.robot % COLORS.length];
    const points = t.poses.map((p) => new THREE.Vector3(p[0], p[1], p[2]));
    const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(points),
      new THREE.LineBasicMaterial({ color }));
    line.name = "trajectory";
    world.add(line);
    const target = new THREE.Group();
    target.add(new THREE.AxesHelper(0.08));
    target.add(new THREE.Mesh(new THREE.SphereGeometry(0.012, 16, 8),
      new THREE.MeshBasicMaterial({ color })));
    world.add(target);
    return { t, target };
  });

  // ---- obstacles (capsule and cylinder axes along their local z)
  const obstacleMaterial = new THREE.MeshStandardMaterial({ color: 0x9aa0aa, transparent: true, opacity: 0.8 });
  for (const o of data.obstacles) {
    let g;
    if (o.shape === "box") g = new THREE.BoxGeometry(...o.half_extents.map((h) => 2 * h));
    else if (o.shape === "sphere") g = new THREE.SphereGeometry(o.radius, 24, 16);
    else if (o.shape === "capsule") g = new THREE.CapsuleGeometry(o.radius, 2 * o.half_length, 6, 16).rotateX(Math.PI / 2);
    else g = new THREE.CylinderGeometry(o.radius, o.radius, 2 * o.half_length, 24).rotateX(Math.PI / 2);
    const m = new THREE.Mesh(g, obstacleMaterial);
    m.name = "obstacle";
    m.position.set(...o.pose.position);
    m.quaternion.set(...o.pose.quat_xyzw);
    world.add(m);
  }

  // ---- panel: what is shown, who tracks what, what the validator found
  const steps = Math.max(1, data.steps);
  // Frames before `lead` are the approach from where the arms stand (0 = initial).
  const lead = data.lead || 0;
  const label = (t) => t < lead ? "approach " + t + " / " + lead : "step " + (t - lead) + " / " + (steps - lead - 1);
  el("title").textContent = data.name;
  const sol = data.solution;
  el("status").innerHTML = sol === null
    ? "problem only: no solution given (arms at their initial configurations)"
    : escape(sol.planner) + ": " + escape(sol.status) +
      (sol.status === "solved" ? ", " + (1000 * sol.planning_time_s).toFixed(1) + " ms" : "") +
      ' &mdash; <span class="' + (sol.valid ? "ok" : "bad") + '">' + escape(sol.summary) + "</span>" +
      (sol.message ? "<br>" + escape(sol.message) : "");
  el("legend").innerHTML = data.robots.map((r, i) =>
    '<li><span class="swatch" style="background:' + hex(COLORS[i % COLORS.length]) + '"></span>' +
    escape(r.name) + " &rarr; " +
    (r.trajectory === null ? "holds" : escape(data.trajectories[r.trajectory].name)) + "</li>").join("");
  const violations = sol === null ? [] : sol.violations;
  // A finding's frame on the timeline: approach steps count from `initial` (frame 0).
  const frameOf = (v) => v.step === null ? null : (v.phase === "approach" ? v.step : v.step + lead);
  el("violations").innerHTML = violations.map((v, k) =>
    '<li data-k="' + k + '">' + escape(v.rule) +
    (v.step === null ? "" : (v.phase === "approach" ? ", approach step " : ", step ") + v.step) +
    ": " + escape(v.detail) + "</li>").join("");
  for (const li of el("violations").children) {
    li.onclick = () => {
      const t = frameOf(violations[+li.dataset.k]);
      if (t !== null) setStep(t);
    };
  }

  // ---- stepping
  const slider = el("slider");
  slider.max = String(steps - 1);
  if (lead > 0) {
    // The approach's part of the track in amber, with its name under it.
    const f = (100 * lead / Math.max(1, steps - 1)).toFixed(2) + "%";
    slider.style.background = "linear-gradient(to right, #f0b429 0 " + f + ", #c9d3e0 " + f + " 100%)";
    el("phase").textContent = "approach: " + (lead * data.dt).toFixed(1) + " s, then the path";
  }
  let step = 0;
  function setStep(t) {
    step = Math.min(steps - 1, Math.max(0, Math.round(t)));
    slider.value = String(step);
    for (const { robot, links } of arms) {
      const frames = robot.frames[Math.min(step, robot.frames.length - 1)];
      links.forEach((link, l) => {
        const f = frames[l];
        link.matrix.set(f[0], f[3], f[6], f[9], f[1], f[4], f[7], f[10], f[2], f[5], f[8], f[11], 0, 0, 0, 1);
        link.matrixWorldNeedsUpdate = true;
        link.userData.material.color.setHex(link.userData.color);
        link.userData.material.emissive.setHex(0);
      });
    }
    // Collisions at this step (or on the motion leaving it): their links in red.
    const now = violations.filter((v) => frameOf(v) === step && v.links && v.links.length);
    for (const v of now) {
      for (const [r, l] of v.links) {
        const m = arms[r].links[l].userData.material;
        m.color.setHex(CLASH);
        m.emissive.setHex(0x550000);
      }
    }
    for (const li of el("violations").children) {
      li.classList.toggle("now", frameOf(violations[+li.dataset.k]) === step);
    }
    el("clash").textContent = now.length ? label(step).split(" /")[0] + ": " + now.map((v) => v.detail).join("; ") : "";
    for (const { t, target } of targets) {
      const p = t.poses[Math.min(Math.max(0, step - lead), t.poses.length - 1)];
      if (!p) continue;
      target.position.set(p[0], p[1], p[2]);
      target.quaternion.set(p[3], p[4], p[5], p[6]);
    }
    el("counter").textContent = label(step) + "  (" + (step * data.dt).toFixed(2) + " s)";
    el("counter").classList.toggle("approach", step < lead);
    world.updateMatrixWorld(true);
  }
  slider.addEventListener("input", () => setStep(+slider.value));

  let playing = false, last = null, carried = 0;
  el("play").onclick = () => {
    playing = !playing;
    if (playing && step === steps - 1) setStep(0);
    el("play").textContent = playing ? "Pause" : "Play";
    last = null;
  };
  el("capsules").onchange = (e) => {
    for (const m of capsuleObjects) m.visible = e.target.checked || m.userData.always;
    for (const { links } of arms) for (const l of links) for (const c of l.children) {
      if (!capsuleObjects.includes(c)) c.visible = !e.target.checked;
    }
  };

  // ---- camera on everything
  const bounds = new THREE.Box3();
  for (const r of data.robots) for (const f of r.frames[0]) bounds.expandByPoint(new THREE.Vector3(f[9], f[10], f[11]));
  for (const t of data.trajectories) for (const p of t.poses) bounds.expandByPoint(new THREE.Vector3(p[0], p[1], p[2]));
  const centre = bounds.isEmpty() ? new THREE.Vector3(0, 0, 0.4) : bounds.getCenter(new THREE.Vector3());
  const radius = bounds.isEmpty() ? 1 : Math.max(0.6, bounds.getSize(new THREE.Vector3()).length() / 2 + 0.4);
  camera.position.copy(centre).add(new THREE.Vector3(1.2, -1.9, 1.3).multiplyScalar(radius * 0.9));
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(centre);
  controls.update();

  function resize() {
    const w = box.clientWidth, h = Math.max(1, box.clientHeight);
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }
  window.addEventListener("resize", resize);
  resize();

  function frame(now) {
    if (playing) {
      if (last !== null) carried += (now - last) / 1000;
      last = now;
      if (carried >= data.dt) {
        carried = 0;
        if (step + 1 >= steps) { playing = false; el("play").textContent = "Play"; }
        else setStep(step + 1);
      }
    }
    controls.update();
    renderer.render(world, camera);
    requestAnimationFrame(frame);
  }

  // The joint angles as drawn: from the world frames of each joint's two link objects,
  // rel = parent^T child = origin * rot(axis, q).
  function jointAngles() {
    return arms.map(({ links, joints }) => joints.map((j) => {
      const rot = (obj) => new THREE.Matrix3().setFromMatrix4(obj.matrixWorld);
      const o = new THREE.Matrix3().fromArray(j.origin);
      const m = o.transpose().multiply(rot(links[j.parent]).transpose()).multiply(rot(links[j.child]));
      const e = m.elements; // column-major
      const s = 0.5 * ((e[5] - e[7]) * j.axis[0] + (e[6] - e[2]) * j.axis[1] + (e[1] - e[3]) * j.axis[2]);
      const c = 0.5 * (e[0] + e[4] + e[8] - 1);
      return Math.atan2(s, c);
    }));
  }

  Object.assign(view, {
    steps,
    lead,
    arms: () => world.children.filter((o) => o.name === "arm").length,
    step: () => step,
    setStep,
    jointAngles,
    // Per robot: its model's name and how many of its links are drawn with a mesh.
    models: () => arms.map(({ robot, links }) => [data.models[robot.model].name,
      links.filter((l) => l.children.some((c) => !capsuleObjects.includes(c))).length]),
    // [robot, link name] of every link drawn in the clash colour.
    marked: () => arms.flatMap(({ links }, r) => links
      .filter((l) => l.userData.material.color.getHex() === CLASH)
      .map((l) => [r, l.name])),
  });
  setStep(0);
  renderer.render(world, camera);
  requestAnimationFrame(frame);
  view.ready = true;
}
