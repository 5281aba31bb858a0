// The page scene_graph.html is made of: its head, then three.js, then the data (const QSG_DATA = {...}), then the
// viewer below (graph_viewer.cc fills it in). Plain WebGL through three.js r111 (Debian's libjs-three); z is up.
#pragma once

namespace qsg::app::viewer_page {

inline constexpr const char* kHead = R"HTML(<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>scene graph</title>
<style>
body { margin: 0; overflow: hidden; font: 13px sans-serif; }
.box { position: absolute; background: rgba(255, 255, 255, 0.92); border: 1px solid #bbb; border-radius: 4px;
       padding: 6px 10px; }
#panel { top: 8px; left: 8px; line-height: 1.6; }
#info { bottom: 8px; left: 8px; max-width: 45%; white-space: pre; font-family: monospace; display: none; }
#help { top: 8px; right: 8px; color: #555; }
.swatch { display: inline-block; width: 10px; height: 10px; margin: 0 4px 0 2px; border: 1px solid #888; }
</style></head>
<body><div id="panel" class="box"></div><div id="info" class="box"></div>
<div id="help" class="box">drag: turn &middot; shift-drag or right-drag: pan &middot; wheel: zoom &middot; click a node</div>
)HTML";

inline constexpr const char* kViewer = R"JS(
(function () {
  const D = QSG_DATA;
  const bytes = (s) => { const b = atob(s); const a = new Uint8Array(b.length); for (let i = 0; i < b.length; ++i) a[i] = b.charCodeAt(i); return a.buffer; };
  const hidden = new Set((location.hash.match(/hide=([^&]*)/) || [null, ''])[1].split(',').filter((s) => s));
  const renderer = new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
  renderer.setPixelRatio(1);
  renderer.setSize(window.innerWidth, window.innerHeight);
  document.body.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xffffff);
  const camera = new THREE.PerspectiveCamera(45, window.innerWidth / window.innerHeight, 0.05, 10000);
  camera.up.set(0, 0, 1);
  const groups = [];
  const addGroup = (key, title, color) => { const g = new THREE.Group(); g.name = key; g.userData.title = title; g.userData.color = color; scene.add(g); groups.push(g); return g; };
  const rgb = (c) => new THREE.Color(c[0] / 255, c[1] / 255, c[2] / 255);

  if (D.mesh) {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(bytes(D.mesh.positions)), 3));
    g.setAttribute('color', new THREE.BufferAttribute(new Uint8Array(bytes(D.mesh.colors)), 3, true));
    g.setIndex(new THREE.BufferAttribute(new Uint32Array(bytes(D.mesh.indices)), 1));
    addGroup('mesh', 'mesh (by label)', null).add(new THREE.Mesh(g, new THREE.MeshBasicMaterial({vertexColors: THREE.VertexColors, side: THREE.DoubleSide})));
  }
  const lines = (coords, color, opacity) => {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(coords, 3));
    return new THREE.LineSegments(g, new THREE.LineBasicMaterial({color: color, transparent: opacity < 1, opacity: opacity}));
  };
  const pickable = [];
  for (const L of D.layers) {
    if (L.positions.length === 0) continue;
    const group = addGroup(L.key, L.title, L.color);
    if (L.edges.length) group.add(lines(L.edges, rgb(L.color), 0.45));
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(L.positions, 3));
    const points = new THREE.Points(g, new THREE.PointsMaterial({color: rgb(L.color), size: L.size_px, sizeAttenuation: false}));
    points.userData.info = L.info;
    group.add(points);
    pickable.push(points);
  }
  if (D.interlayer.length) addGroup('edges', 'edges between layers', [150, 150, 150]).add(lines(D.interlayer, 0x969696, 0.6));
  if (D.labels.length) {
    const names = addGroup('names', 'room names', null);
    for (const t of D.labels) {
      const canvas = document.createElement('canvas');
      canvas.width = 512; canvas.height = 96;
      const c = canvas.getContext('2d');
      c.font = 'bold 56px sans-serif'; c.textAlign = 'center'; c.textBaseline = 'middle';
      c.lineWidth = 10; c.strokeStyle = 'white'; c.strokeText(t.text, 256, 48);
      c.fillStyle = '#202020'; c.fillText(t.text, 256, 48);
      const sprite = new THREE.Sprite(new THREE.SpriteMaterial({map: new THREE.CanvasTexture(canvas), depthTest: false, transparent: true}));
      sprite.position.set(t.position[0], t.position[1], t.position[2]);
      sprite.scale.set(D.label_height_m * 512 / 96, D.label_height_m, 1);
      names.add(sprite);
    }
  }

  const panel = document.getElementById('panel');
  panel.innerHTML = '<b>' + D.title + '</b><br>';
  for (const g of groups) {
    const row = document.createElement('label');
    const box = document.createElement('input');
    box.type = 'checkbox'; box.checked = !hidden.has(g.name); g.visible = box.checked;
    box.onchange = () => { g.visible = box.checked; render(); };
    row.appendChild(box);
    if (g.userData.color) { const s = document.createElement('span'); s.className = 'swatch'; s.style.background = 'rgb(' + g.userData.color.join(',') + ')'; row.appendChild(s); }
    row.appendChild(document.createTextNode(g.userData.title));
    panel.appendChild(row); panel.appendChild(document.createElement('br'));
  }

  const target = new THREE.Vector3(D.center[0], D.center[1], D.center[2]);
  let radius = D.radius * 2.6, azimuth = -Math.PI / 2, polar = 0.95;
  function render() {
    camera.position.set(target.x + radius * Math.sin(polar) * Math.cos(azimuth), target.y + radius * Math.sin(polar) * Math.sin(azimuth),
                        target.z + radius * Math.cos(polar));
    camera.lookAt(target);
    renderer.render(scene, camera);
  }
  let down = null;
  renderer.domElement.addEventListener('contextmenu', (e) => e.preventDefault());
  renderer.domElement.addEventListener('pointerdown', (e) => { down = {x: e.clientX, y: e.clientY, lx: e.clientX, ly: e.clientY, pan: e.shiftKey || e.button === 2}; });
  window.addEventListener('pointermove', (e) => {
    if (!down) return;
    const dx = e.clientX - down.lx, dy = e.clientY - down.ly;
    down.lx = e.clientX; down.ly = e.clientY;
    if (down.pan) {
      const right = new THREE.Vector3().setFromMatrixColumn(camera.matrix, 0), up = new THREE.Vector3().setFromMatrixColumn(camera.matrix, 1);
      target.addScaledVector(right, -dx * radius * 0.0015).addScaledVector(up, dy * radius * 0.0015);
    } else {
      azimuth -= dx * 0.008;
      polar = Math.min(3.1, Math.max(0.02, polar - dy * 0.008));
    }
    render();
  });
  window.addEventListener('pointerup', (e) => {
    if (down && Math.abs(e.clientX - down.x) + Math.abs(e.clientY - down.y) < 4) pick(e);
    down = null;
  });
  renderer.domElement.addEventListener('wheel', (e) => { e.preventDefault(); radius *= Math.exp(e.deltaY * 0.001); render(); }, {passive: false});
  window.addEventListener('resize', () => { camera.aspect = window.innerWidth / window.innerHeight; camera.updateProjectionMatrix(); renderer.setSize(window.innerWidth, window.innerHeight); render(); });
  const raycaster = new THREE.Raycaster();
  function pick(e) {
    const mouse = new THREE.Vector2(e.clientX / window.innerWidth * 2 - 1, -e.clientY / window.innerHeight * 2 + 1);
    raycaster.setFromCamera(mouse, camera);
    raycaster.params.Points.threshold = radius * 0.008;
    const hits = raycaster.intersectObjects(pickable.filter((p) => p.parent.visible));
    const info = document.getElementById('info');
    if (hits.length === 0) { info.style.display = 'none'; return; }
    info.textContent = hits[0].object.userData.info[hits[0].index];
    info.style.display = 'block';
  }
  render();
  window.QSG_DRAWN = true;
})();
)JS";

}  // namespace qsg::app::viewer_page
