/* sdovon-mj viewer: a run's scenes, variants, episodes and evaluated trajectories in 3D (three.js, WebGL).
 *
 * Data comes as classic scripts data/<key>.js calling SDOVON_DATA(key, payload) (sdovon_mj/viewer/site.py), so
 * the page works served and from file://. World frame: MuJoCo's, metres, Z up. State lives in the URL hash
 * (#scene=i&variant=j&episode=ID&agent=NAME), so a view can be linked.
 * The page reports its state on <body data-state="loading|ready|error" data-episode=... data-frames=...>.
 */
(function () {
  'use strict';
  const T = window.THREE;
  const FORMAT = 1;
  const CUT_ABOVE_FLOOR = 1.6;  // default cut (m above the top floor): a dollhouse view over the walls, tall furniture cut
  const $ = (id) => document.getElementById(id);
  const store = {};
  const pending = {};
  window.SDOVON_DATA = function (key, payload) { store[key] = payload; };

  function load(key) {
    if (store[key]) return Promise.resolve(store[key]);
    if (pending[key]) return pending[key];
    pending[key] = new Promise((resolve, reject) => {
      const s = document.createElement('script');
      s.src = 'data/' + key + '.js';
      s.onload = () => {
        delete pending[key];
        if (!store[key]) { reject(new Error('data/' + key + '.js did not define its data')); return; }
        if (store[key].format !== FORMAT) { reject(new Error('data format ' + store[key].format + ', page expects ' + FORMAT)); return; }
        resolve(store[key]);
      };
      s.onerror = () => { delete pending[key]; reject(new Error('could not load data/' + key + '.js')); };
      document.head.appendChild(s);
    });
    return pending[key];
  }

  function decode(a) {
    const bin = atob(a.b64);
    const u8 = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
    switch (a.dtype) {
      case 'f4': return new Float32Array(u8.buffer);
      case 'u4': return new Uint32Array(u8.buffer);
      case 'i4': return new Int32Array(u8.buffer);
      case 'u2': return new Uint16Array(u8.buffer);
      case 'i2': return new Int16Array(u8.buffer);
      default: return u8;
    }
  }

  const SRGB_TO_LINEAR = new Float32Array(256);
  for (let i = 0; i < 256; i++) { const c = i / 255; SRGB_TO_LINEAR[i] = c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4); }

  function hexRgb(hex) { const n = parseInt(hex.slice(1), 16); return [(n >> 16) & 255, (n >> 8) & 255, n & 255]; }

  // ---- renderer, camera, controls -----------------------------------------------------------------------------
  const view = $('view');
  const renderer = new T.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.localClippingEnabled = true;
  view.insertBefore(renderer.domElement, view.firstChild);
  const scene3 = new T.Scene();
  scene3.background = new T.Color('#1e2127');
  const camera = new T.PerspectiveCamera(50, 1, 0.05, 500);
  camera.up.set(0, 0, 1);
  const controls = new T.OrbitControls(camera, renderer.domElement);
  controls.addEventListener('change', () => requestRender());
  scene3.add(new T.HemisphereLight(0xffffff, 0x505560, 2.2));
  const sun = new T.DirectionalLight(0xffffff, 1.4);
  sun.position.set(3, -4, 8);
  scene3.add(sun);
  const clipPlane = new T.Plane(new T.Vector3(0, 0, -1), 2.2);

  const groups = {};
  const LAYERS = [
    ['scene', 'Scene', true], ['ceiling', 'Ceiling', false], ['objects', 'Objects', true], ['labels', 'Labels', true],
    ['regions', 'Region map', true], ['navmap', 'Navigable', false], ['planes', 'Receptacles', true],
    ['starts', 'Starts', true], ['goals', 'Goals + views', true], ['trajectory', 'Trajectory', true],
  ];
  for (const [key, title, on] of LAYERS) {
    const g = new T.Group(); g.name = key; g.visible = on; groups[key] = g;
    if (key !== 'labels') scene3.add(g);
    const lab = document.createElement('label');
    const box = document.createElement('input');
    box.type = 'checkbox'; box.checked = on; box.id = 'layer-' + key;
    box.addEventListener('change', () => { g.visible = box.checked; requestRender(); });
    lab.appendChild(box); lab.appendChild(document.createTextNode(' ' + title));
    $('layers').appendChild(lab);
  }

  function clear(group) {
    if (group.userData.dispose) { group.userData.dispose(); delete group.userData.dispose; }
    for (const c of [...group.children]) {
      group.remove(c);
      c.traverse((o) => {
        if (o.geometry && !o.userData.sharedGeometry) o.geometry.dispose();
        if (o.material && !o.userData.sharedMaterial) {
          if (o.material.map) o.material.map.dispose();
          o.material.dispose();
        }
      });
    }
  }

  let renderQueued = false;
  let frames = 0;
  const labelEls = [];
  function requestRender() {
    if (renderQueued) return;
    renderQueued = true;
    requestAnimationFrame(() => { renderQueued = false; renderNow(); });
  }
  function renderNow() {
    renderer.render(scene3, camera);
    frames += 1;
    document.body.dataset.frames = String(frames);
    placeLabels();
  }
  function resize() {
    const w = view.clientWidth, h = view.clientHeight;
    renderer.setSize(w, h);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
    requestRender();
  }
  window.addEventListener('resize', resize);

  // ---- labels and tooltip -------------------------------------------------------------------------------------
  const tmp = new T.Vector3();
  function placeLabels() {
    const show = $('layer-labels').checked && $('layer-objects').checked;
    const w = view.clientWidth, h = view.clientHeight;
    for (const l of labelEls) {
      tmp.copy(l.pos).project(camera);
      const inside = tmp.z < 1 && tmp.x > -1 && tmp.x < 1 && tmp.y > -1 && tmp.y < 1;
      l.el.style.display = show && inside ? 'block' : 'none';
      if (show && inside) l.el.style.transform = 'translate(' + ((tmp.x + 1) / 2 * w).toFixed(1) + 'px,' + ((1 - tmp.y) / 2 * h).toFixed(1) + 'px) translate(-50%, -100%)';
    }
  }
  function clearLabels() { for (const l of labelEls) l.el.remove(); labelEls.length = 0; }
  function addLabel(text, pos, color, cls) {
    const el = document.createElement('div');
    el.textContent = text; el.style.borderLeftColor = color; el.style.left = '0'; el.style.top = '0';
    if (cls) el.className = cls;
    $('labels').appendChild(el);
    labelEls.push({ el, pos: pos.clone() });
  }

  const raycaster = new T.Raycaster();
  const pointer = new T.Vector2();
  let hoverQueued = false, lastEvent = null;
  renderer.domElement.addEventListener('pointermove', (ev) => {
    lastEvent = ev;
    if (hoverQueued) return;
    hoverQueued = true;
    setTimeout(() => { hoverQueued = false; hover(lastEvent); }, 80);
  });
  renderer.domElement.addEventListener('pointerleave', () => { $('tooltip').style.display = 'none'; });
  function hover(ev) {
    const r = renderer.domElement.getBoundingClientRect();
    pointer.set(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1);
    raycaster.setFromCamera(pointer, camera);
    const targets = [];
    for (const k of ['objects', 'planes', 'starts', 'scene']) if (groups[k].visible) targets.push(groups[k]);
    const hits = raycaster.intersectObjects(targets, true).filter((h) => h.object.userData.tip || h.object.userData.faceTip);
    const tip = $('tooltip');
    if (!hits.length) { tip.style.display = 'none'; return; }
    const h = hits[0];
    tip.textContent = h.object.userData.tip || h.object.userData.faceTip(h.faceIndex);
    tip.style.left = (ev.clientX - r.left + 12) + 'px';
    tip.style.top = (ev.clientY - r.top + 12) + 'px';
    tip.style.display = 'block';
  }

  // ---- builders -----------------------------------------------------------------------------------------------
  function meshGeometry(m) {
    const g = new T.BufferGeometry();
    g.setAttribute('position', new T.BufferAttribute(decode(m.positions), 3));
    const c8 = decode(m.colors);
    const col = new Float32Array(c8.length);
    for (let i = 0; i < c8.length; i++) col[i] = SRGB_TO_LINEAR[c8[i]];
    g.setAttribute('color', new T.BufferAttribute(col, 3));
    g.setIndex(new T.BufferAttribute(decode(m.indices), 1));
    g.computeVertexNormals();
    return g;
  }

  function gridTexture(grid, colorOf) {
    const [h, w] = grid.shape;
    const cells = decode(grid.cells);
    const rgba = new Uint8Array(w * h * 4);
    for (let i = 0; i < w * h; i++) {
      const c = colorOf(cells[i]);
      if (c) { rgba[4 * i] = c[0]; rgba[4 * i + 1] = c[1]; rgba[4 * i + 2] = c[2]; rgba[4 * i + 3] = c[3]; }
    }
    const tex = new T.DataTexture(rgba, w, h, T.RGBAFormat);
    tex.colorSpace = T.SRGBColorSpace;
    tex.magFilter = T.NearestFilter; tex.minFilter = T.NearestFilter;
    tex.needsUpdate = true;
    return tex;
  }

  function gridPlane(grid, z, tex, opacity) {
    const [h, w] = grid.shape;
    const sx = w * grid.resolution, sy = h * grid.resolution;
    const mat = new T.MeshBasicMaterial({ map: tex, transparent: true, opacity, depthWrite: false, side: T.DoubleSide,
      polygonOffset: true, polygonOffsetFactor: -2, polygonOffsetUnits: -2 });
    const mesh = new T.Mesh(new T.PlaneGeometry(sx, sy), mat);
    mesh.position.set(grid.origin[0] + sx / 2, grid.origin[1] + sy / 2, z);
    mesh.renderOrder = 1;
    return mesh;
  }

  let index = null, sceneData = null, variantData = null;
  const sel = { scene: 0, variant: 0, episode: null, agent: '' };
  let fittedScene = -1;

  function buildScene(s) {
    clear(groups.scene); clear(groups.ceiling); clear(groups.regions); clear(groups.navmap); clear(groups.planes);
    const mat = new T.MeshLambertMaterial({ vertexColors: true, flatShading: true, side: T.DoubleSide, clippingPlanes: [clipPlane] });
    const main = new T.Mesh(meshGeometry(s.mesh), mat);
    const ids = decode(s.mesh.face_id);
    main.userData.faceTip = (f) => { const id = ids[f]; return id >= 0 ? (s.instances[String(id)] || 'instance') + ' (instance ' + id + ')' : 'scene'; };
    groups.scene.add(main);
    if (s.ceiling.indices.shape[0] > 0) groups.ceiling.add(new T.Mesh(meshGeometry(s.ceiling), new T.MeshLambertMaterial({ vertexColors: true, flatShading: true, side: T.DoubleSide })));
    for (const r of s.regions) {
      const cols = r.labels.map((l) => { const c = hexRgb(index.regions[l] || '#888888'); return [c[0], c[1], c[2], 255]; });
      const tex = gridTexture(r.grid, (v) => (v > 0 ? cols[v - 1] : null));
      groups.regions.add(gridPlane(r.grid, r.height + 0.012, tex, 0.62));
    }
    for (const f of s.floors) {
      const tex = gridTexture(f.navmap, (v) => (v === 2 ? [80, 200, 120, 255] : null));
      groups.navmap.add(gridPlane(f.navmap, f.height + 0.018, tex, 0.45));
    }
    for (const p of s.planes) {
      if (p.polygon.length < 3) continue;
      const shape = new T.Shape(p.polygon.map(([x, y]) => new T.Vector2(x, y)));
      const fill = new T.Mesh(new T.ShapeGeometry(shape), new T.MeshBasicMaterial({ color: '#ffb454', transparent: true,
        opacity: 0.45, side: T.DoubleSide, depthWrite: false, polygonOffset: true, polygonOffsetFactor: -2, polygonOffsetUnits: -2 }));
      fill.position.z = p.height + 0.01;
      fill.userData.tip = p.label + (p.region ? ' in ' + p.region : '') + '\nplane ' + p.id + ', ' + p.height.toFixed(2) + ' m' + (p.part ? '\ninside, closed by ' + p.part : '');
      const pts = p.polygon.map(([x, y]) => new T.Vector3(x, y, p.height + 0.012));
      const edge = new T.LineLoop(new T.BufferGeometry().setFromPoints(pts), new T.LineBasicMaterial({ color: '#ff8f1f' }));
      groups.planes.add(fill); groups.planes.add(edge);
    }
    // the cut height slider spans the scene's height
    const zmin = s.bounds[0][2], zmax = s.bounds[1][2];
    const floor0 = s.floors.length ? Math.max(...s.floors.map((f) => f.height)) : zmin;
    const clip = $('clip');
    clip.min = String(zmin.toFixed(2)); clip.max = String((zmax + 0.1).toFixed(2));
    clip.value = String(Math.min(zmax + 0.1, floor0 + CUT_ABOVE_FLOOR).toFixed(2));
    setClip();
    legend('legend-regions', s.regions.flatMap((r) => r.labels).filter((v, i, a) => a.indexOf(v) === i).sort(), index.regions);
  }

  function setClip() { clipPlane.constant = parseFloat($('clip').value); $('clip-value').textContent = parseFloat($('clip').value).toFixed(2) + ' m'; requestRender(); }
  $('clip').addEventListener('input', setClip);

  function buildVariant(v) {
    clear(groups.objects); clearLabels();
    const geoms = {};
    for (const [name, m] of Object.entries(v.assets)) geoms[name] = meshGeometry(m);
    const mats = {};
    const shown = [];
    for (const o of v.objects) {
      const color = index.categories[o.category] || '#cccccc';
      if (!mats[color]) mats[color] = new T.MeshLambertMaterial({ color, flatShading: true, side: T.DoubleSide });
      let mesh;
      if (geoms[o.asset]) {
        mesh = new T.Mesh(geoms[o.asset], mats[color]);
        mesh.userData.sharedGeometry = true;
      } else {
        mesh = new T.Mesh(new T.SphereGeometry(0.06, 12, 8), mats[color]);
      }
      mesh.userData.sharedMaterial = true;
      mesh.position.set(o.position[0], o.position[1], o.position[2]);
      mesh.quaternion.set(o.quat[1], o.quat[2], o.quat[3], o.quat[0]);  // records are wxyz, three.js xyzw
      mesh.userData.tip = o.category + ' (' + o.id + ', ' + o.asset + ')\n' + o.status + (o.region ? ' in ' + o.region : '') + (o.part ? '\ninside, behind ' + o.part : '');
      mesh.userData.objectId = o.id;
      groups.objects.add(mesh);
      const top = o.bbox ? o.bbox[1][2] : 0.1;
      addLabel(o.category, new T.Vector3(o.position[0], o.position[1], o.position[2] + top + 0.05), color);
      shown.push(o);
    }
    // dispose per-variant shared resources with the group: keep references on the group
    groups.objects.userData.dispose = () => { Object.values(geoms).forEach((g) => g.dispose()); Object.values(mats).forEach((m) => m.dispose()); };
    if (v.parts.indices.shape[0] > 0) {
      const parts = new T.Mesh(meshGeometry(v.parts), new T.MeshLambertMaterial({ vertexColors: true, flatShading: true, side: T.DoubleSide, clippingPlanes: [clipPlane] }));
      groups.objects.add(parts);
    }
    legend('legend-categories', [...new Set(v.objects.map((o) => o.category))].sort(), index.categories);
    // all episode starts, small and grey; the selected one is drawn again by buildEpisode
    clear(groups.starts);
    const arrowGeom = startArrow(0.09, 0.28);
    const grey = new T.MeshLambertMaterial({ color: '#aab2bd' });
    for (const e of v.episodes) {
      const a = new T.Mesh(arrowGeom, grey);
      a.userData.sharedGeometry = true; a.userData.sharedMaterial = true;
      a.position.set(e.start[0], e.start[1], e.start[2] + 0.05);
      a.rotation.z = e.yaw * Math.PI / 180;
      a.userData.tip = 'start of ' + e.id + ': find ' + e.category;
      groups.starts.add(a);
    }
    groups.starts.userData.dispose = () => { arrowGeom.dispose(); grey.dispose(); };
  }

  function startArrow(r, len) {  // a cone pointing along +X
    const g = new T.ConeGeometry(r, len, 16);
    g.rotateZ(-Math.PI / 2);
    return g;
  }

  function buildEpisode(v, e) {
    clear(groups.goals); clear(groups.trajectory);
    for (const l of labelEls) l.el.classList.remove('goal');
    if (!e) return;
    const green = '#39d353';
    const goalIds = new Set(e.goals);
    for (const oid of e.goals) {
      const g = v.goals[oid];
      if (!g) continue;
      if (g.bounds) groups.goals.add(new T.Box3Helper(new T.Box3(new T.Vector3(...g.bounds[0]), new T.Vector3(...g.bounds[1])), green));
      const vp = decode(g.view_points);
      const pos = new Float32Array(vp.length);
      for (let i = 0; i < vp.length; i += 3) { pos[i] = vp[i]; pos[i + 1] = vp[i + 1]; pos[i + 2] = vp[i + 2] + 0.03; }
      const geo = new T.BufferGeometry();
      geo.setAttribute('position', new T.BufferAttribute(pos, 3));
      groups.goals.add(new T.Points(geo, new T.PointsMaterial({ color: green, size: 4, sizeAttenuation: false })));
    }
    v.objects.forEach((o, i) => { if (goalIds.has(o.id) && labelEls[i]) labelEls[i].el.classList.add('goal'); });
    const a = new T.Mesh(startArrow(0.16, 0.5), new T.MeshLambertMaterial({ color: '#4ea1ff' }));
    a.position.set(e.start[0], e.start[1], e.start[2] + 0.08);
    a.rotation.z = e.yaw * Math.PI / 180;
    a.userData.tip = 'start of ' + e.id + ': find ' + e.category;
    groups.goals.add(a);
    const res = sel.agent && v.results[sel.agent] ? v.results[sel.agent][e.id] : null;
    if (res && res.trajectory.length) {
      const z = e.start[2] + 0.06;
      const ok = !!res.metrics.success;
      const path = new T.Mesh(ribbon(res.trajectory, z, 0.12), new T.MeshBasicMaterial({ color: '#5ce1e6', side: T.DoubleSide }));
      path.userData.tip = sel.agent + ' on ' + e.id;
      groups.trajectory.add(path);
      const last = res.trajectory[res.trajectory.length - 1];
      const end = new T.Mesh(new T.SphereGeometry(0.1, 16, 10), new T.MeshLambertMaterial({ color: ok ? '#39d353' : '#ff5c57' }));
      end.position.set(last[0], last[1], z);
      end.userData.tip = sel.agent + ' stopped here: ' + (res.metrics.outcome || (ok ? 'success' : 'failure'));
      groups.trajectory.add(end);
    }
  }

  function ribbon(points, z, width) {  // a flat strip along a 2D path (WebGL draws lines one pixel wide)
    const pos = [];
    for (let i = 0; i + 1 < points.length; i++) {
      const [x0, y0] = points[i], [x1, y1] = points[i + 1];
      const len = Math.hypot(x1 - x0, y1 - y0);
      if (len < 1e-6) continue;
      const nx = -(y1 - y0) / len * width / 2, ny = (x1 - x0) / len * width / 2;
      pos.push(x0 + nx, y0 + ny, z, x0 - nx, y0 - ny, z, x1 + nx, y1 + ny, z, x0 - nx, y0 - ny, z, x1 - nx, y1 - ny, z, x1 + nx, y1 + ny, z);
    }
    const g = new T.BufferGeometry();
    g.setAttribute('position', new T.BufferAttribute(new Float32Array(pos), 3));
    return g;
  }

  function legend(id, names, colors) {
    const el = $(id);
    el.innerHTML = '';
    for (const n of names) {
      const s = document.createElement('span');
      const i = document.createElement('i');
      i.style.background = colors[n] || '#888';
      s.appendChild(i); s.appendChild(document.createTextNode(n));
      el.appendChild(s);
    }
    if (!names.length) el.textContent = '-';
  }

  function fmt(x, d) { return typeof x === 'number' ? x.toFixed(d) : (x === null || x === undefined ? '-' : String(x)); }

  function episodeTable(v) {
    const head = $('episodes').tHead, body = $('episodes').tBodies[0];
    const agent = sel.agent && v.results[sel.agent] ? v.results[sel.agent] : null;
    head.innerHTML = '<tr><th>episode</th><th>goal</th><th>geo m</th>' + (agent ? '<th>S</th><th>SPL</th>' : '') + '</tr>';
    body.innerHTML = '';
    for (const e of v.episodes) {
      const tr = document.createElement('tr');
      tr.dataset.episode = e.id;
      const r = agent ? agent[e.id] : null;
      const cells = [e.id, e.category, fmt(e.geodesic, 2)];
      if (agent) cells.push(r ? (r.metrics.success ? '\u2713' : '\u2717') : '-', r ? fmt(r.metrics.spl, 2) : '-');
      for (const c of cells) { const td = document.createElement('td'); td.textContent = c; tr.appendChild(td); }
      if (agent && r) tr.children[3].className = r.metrics.success ? 'ok' : 'bad';
      tr.addEventListener('click', () => selectEpisode(e.id));
      body.appendChild(tr);
    }
    $('episode-count').textContent = '(' + v.episodes.length + ')';
  }

  function episodeInfo(v, e) {
    const el = $('episode-info');
    if (!e) { el.textContent = v.episodes.length ? 'Pick an episode below.' : 'This variant has no episodes.'; return; }
    const nvp = e.goals.reduce((n, oid) => n + (v.goals[oid] ? v.goals[oid].view_points.shape[0] : 0), 0);
    let text = e.id + ': find ' + e.category + ' (' + e.goals.length + ' goal' + (e.goals.length === 1 ? '' : 's') + ', ' + nvp +
      ' view points), geodesic ' + fmt(e.geodesic, 2) + ' m, floor ' + e.floor;
    const r = sel.agent && v.results[sel.agent] ? v.results[sel.agent][e.id] : null;
    if (r) {
      const m = r.metrics;
      text += '\n' + sel.agent + ': ' + (m.outcome || (m.success ? 'success' : 'failure')) + ', SPL ' + fmt(m.spl, 3) +
        ', ' + fmt(m.steps, 0) + ' steps, path ' + fmt(m.path_length, 2) + ' m, distance to goal ' + fmt(m.distance_to_goal, 2) + ' m';
    } else if (sel.agent) {
      text += '\n' + sel.agent + ': not evaluated on this episode';
    }
    el.style.whiteSpace = 'pre-line';
    el.textContent = text;
  }

  function fitCamera(s) {  // the scene's box fills the view, seen from the south, about 60 degrees up
    const lo = new T.Vector3(...s.bounds[0]), hi = new T.Vector3(...s.bounds[1]);
    const c = lo.clone().add(hi).multiplyScalar(0.5);
    const dir = new T.Vector3(0.2, -0.48, 0.86).normalize();
    const corners = [];
    for (const x of [lo.x, hi.x]) for (const y of [lo.y, hi.y]) for (const z of [lo.z, hi.z]) corners.push(new T.Vector3(x, y, z));
    let d = hi.clone().sub(lo).length() / 2 / Math.sin((camera.fov * Math.PI / 180) / 2);
    for (let i = 0; i < 4; i++) {  // move in or out until the farthest corner sits at 92 % of the view's half size
      camera.position.copy(c).addScaledVector(dir, d);
      camera.near = Math.max(0.02, d / 500); camera.far = d * 20;
      camera.lookAt(c);
      camera.updateProjectionMatrix();
      camera.updateMatrixWorld();
      let m = 0;
      for (const p of corners) { const q = p.clone().project(camera); m = Math.max(m, Math.abs(q.x), Math.abs(q.y)); }
      d *= Math.min(Math.max(m / 0.92, 0.5), 2.0);
    }
    camera.position.copy(c).addScaledVector(dir, d);
    camera.near = Math.max(0.02, d / 500); camera.far = d * 20;
    camera.updateProjectionMatrix();
    controls.target.copy(c);
    controls.update();
  }

  // ---- state --------------------------------------------------------------------------------------------------
  function writeHash() {
    const q = 'scene=' + sel.scene + '&variant=' + sel.variant + (sel.episode ? '&episode=' + encodeURIComponent(sel.episode) : '') +
      (sel.agent ? '&agent=' + encodeURIComponent(sel.agent) : '');
    try { history.replaceState(null, '', '#' + q); } catch (err) { /* some file:// contexts refuse; the page works without */ }
  }
  function readHash() {
    const out = {};
    for (const part of location.hash.replace(/^#/, '').split('&')) {
      const [k, v] = part.split('=');
      if (k) out[k] = decodeURIComponent(v || '');
    }
    return out;
  }

  function setState(state, why) {
    document.body.dataset.state = state;
    $('status').textContent = why || '';
    $('status').className = state === 'error' ? 'bad' : 'small';
  }
  function ready() {  // after the frame showing the current selection is on screen
    requestRender();
    requestAnimationFrame(() => requestAnimationFrame(() => {
      document.body.dataset.episode = sel.episode || '';
      document.body.dataset.variant = variantData ? variantData.name : '';
      setState('ready', sceneData ? sceneData.name + ': ' + sceneData.faces.shown + ' triangles' +
        (sceneData.faces.shown < sceneData.faces.full ? ' (of ' + sceneData.faces.full + ')' : '') : '');
    }));
  }

  let token = 0;
  async function select(sceneIdx, variantIdx, episode) {
    const my = ++token;
    setState('loading', 'loading...');
    try {
      const sKey = 'scene_' + sceneIdx;
      const s = await load(sKey);
      const hasVariant = index.scenes[sceneIdx].variants.length > 0;
      const v = hasVariant ? await load('variant_' + sceneIdx + '_' + variantIdx) : null;
      if (my !== token) return;
      if (sceneData !== s) { sceneData = s; buildScene(s); }
      if (fittedScene !== sceneIdx) { fitCamera(s); fittedScene = sceneIdx; }
      sel.scene = sceneIdx; sel.variant = variantIdx;
      variantData = v || { name: '', objects: [], assets: {}, parts: { indices: { shape: [0] } }, goals: {}, episodes: [], results: {} };
      buildVariant(variantData);
      episodeTable(variantData);
      const e = variantData.episodes.find((x) => x.id === episode) || null;
      selectEpisode(e ? e.id : null);
    } catch (err) {
      setState('error', String(err.message || err));
      throw err;
    }
  }

  function selectEpisode(id) {
    sel.episode = id;
    const v = variantData;
    const e = v.episodes.find((x) => x.id === id) || null;
    for (const tr of $('episodes').tBodies[0].rows) tr.classList.toggle('selected', tr.dataset.episode === id);
    buildEpisode(v, e);
    episodeInfo(v, e);
    writeHash();
    ready();
  }

  function fillVariants() {
    const vs = index.scenes[sel.scene].variants;
    $('variant').innerHTML = '';
    vs.forEach((v, j) => {
      const o = document.createElement('option');
      o.value = String(j); o.textContent = v.name + ' (' + v.resting + '/' + v.objects + ' objects, ' + v.episodes + ' episodes)';
      $('variant').appendChild(o);
    });
    $('variant').value = String(sel.variant);
  }

  async function main() {
    index = await load('index');
    $('title').textContent = index.title;
    document.title = index.title + ' - sdovon-mj viewer';
    index.scenes.forEach((s, i) => { const o = document.createElement('option'); o.value = String(i); o.textContent = s.name; $('scene').appendChild(o); });
    $('agent-row').style.display = index.agents.length ? 'block' : 'none';
    const none = document.createElement('option'); none.value = ''; none.textContent = '(none)'; $('agent').appendChild(none);
    for (const a of index.agents) { const o = document.createElement('option'); o.value = a; o.textContent = a; $('agent').appendChild(o); }
    const h = readHash();
    sel.scene = Math.min(parseInt(h.scene || '0', 10) || 0, index.scenes.length - 1);
    sel.variant = Math.min(parseInt(h.variant || '0', 10) || 0, Math.max(index.scenes[sel.scene].variants.length - 1, 0));
    sel.agent = h.agent !== undefined ? h.agent : (index.agents[0] || '');
    $('scene').value = String(sel.scene); $('agent').value = sel.agent;
    fillVariants();
    $('scene').addEventListener('change', () => { sel.scene = parseInt($('scene').value, 10); sel.variant = 0; fillVariants(); select(sel.scene, 0, null); });
    $('variant').addEventListener('change', () => select(sel.scene, parseInt($('variant').value, 10), null));
    $('agent').addEventListener('change', () => { sel.agent = $('agent').value; episodeTable(variantData); selectEpisode(sel.episode); });
    resize();
    const first = h.episode !== undefined ? h.episode : null;
    await select(sel.scene, sel.variant, first);
    if (!first && variantData.episodes.length) selectEpisode(variantData.episodes[0].id);
  }

  window.sdovonViewer = {
    selectEpisode: (id) => selectEpisode(id),
    stats: () => ({ triangles: renderer.info.render.triangles, calls: renderer.info.render.calls, frames,
      objects: groups.objects.children.length, labels: labelEls.length, episode: sel.episode,
      webgl: renderer.getContext().getParameter(renderer.getContext().VERSION) }),
  };
  main().catch((err) => { setState('error', String(err.message || err)); console.error(err); });
})();
