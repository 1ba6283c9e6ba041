// furnidet's 3-D scene view: draws window.FURN_SCENE (scene_data.js, written
// by reports/scene_view.cc) with three.js. World frame: metres, z up (REP 103).
// With #selftest in the address the page checks itself once it has drawn and
// writes what it found into <pre id="scene-check"> (tests read it).
(function () {
  'use strict';

  var errors = [];
  window.addEventListener('error', function (event) { errors.push(String(event.message)); });
  var consoleError = console.error;
  console.error = function () {
    errors.push(Array.prototype.join.call(arguments, ' '));
    consoleError.apply(console, arguments);
  };

  var data = window.FURN_SCENE;
  if (!window.THREE || !THREE.OrbitControls || !data) {
    document.getElementById('fallback').textContent =
        'The scene cannot be shown: three.js or scene_data.js did not load (open the page from ' +
        'its folder, with the report\'s three/ folder beside it).';
    errors.push('missing three.js or scene data');
    return;
  }

  var canvas = document.getElementById('view');
  var renderer = new THREE.WebGLRenderer({canvas: canvas, antialias: true,
                                          preserveDrawingBuffer: true});
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(0x15171a);
  var scene = new THREE.Scene();
  var camera = new THREE.PerspectiveCamera(55, 1, 0.02, 200);
  camera.up.set(0, 0, 1);
  var controls = new THREE.OrbitControls(camera, canvas);
  var origin = new THREE.Vector3(data.origin[0], data.origin[1], data.origin[2]);
  var layers = {};
  var pickable = [];
  var counts = {points: data.points.count, fitted: data.fitted.count, truth: data.truth.length,
                detections: data.detections.length, maxima: data.maxima.length};

  function decodeInt16(base64) {
    var text = atob(base64);
    var bytes = new Uint8Array(text.length);
    for (var i = 0; i < text.length; ++i) bytes[i] = text.charCodeAt(i);
    return new Int16Array(bytes.buffer);
  }

  function positionsOf(block) {
    var mm = decodeInt16(block.xyz_mm);
    var positions = new Float32Array(mm.length);
    for (var i = 0; i < mm.length; i += 3) {
      positions[i] = origin.x + mm[i] / 1000;
      positions[i + 1] = origin.y + mm[i + 1] / 1000;
      positions[i + 2] = origin.z + mm[i + 2] / 1000;
    }
    return positions;
  }

  function addLayer(name, label, group, visible) {
    group.name = name;
    group.visible = visible;
    scene.add(group);
    layers[name] = group;
    var box = document.createElement('input');
    box.type = 'checkbox';
    box.checked = visible;
    box.id = 'layer-' + name;
    box.addEventListener('change', function () { setLayer(name, box.checked); });
    var line = document.createElement('label');
    line.appendChild(box);
    line.appendChild(document.createTextNode(' ' + label));
    document.getElementById('layers').appendChild(line);
  }

  function setLayer(name, visible) {
    layers[name].visible = visible;
    document.getElementById('layer-' + name).checked = visible;
    render();
  }

  // Points: coloured by height (blue low, red high) or by segment.
  var pointPositions = positionsOf(data.points);
  var pointGeometry = new THREE.BufferGeometry();
  pointGeometry.setAttribute('position', new THREE.BufferAttribute(pointPositions, 3));
  var pointColours = new Float32Array(pointPositions.length);
  pointGeometry.setAttribute('color', new THREE.BufferAttribute(pointColours, 3));
  var segments = data.points.segment ? decodeInt16(data.points.segment) : null;
  if (!segments) document.querySelector('#colour-by option[value=segment]').disabled = true;

  function colourPoints(by) {
    var colour = new THREE.Color();
    for (var i = 0; i < data.points.count; ++i) {
      if (by === 'segment' && segments) {
        var s = segments[i];
        if (s < 0) colour.setRGB(0.35, 0.35, 0.35);
        else colour.setHSL(((s * 137.508) % 360) / 360, 0.75, 0.55);
      } else {
        var z = Math.min(Math.max(pointPositions[3 * i + 2] / 2.0, 0), 1);
        colour.setHSL(0.66 * (1 - z), 0.8, 0.55);
      }
      pointColours[3 * i] = colour.r;
      pointColours[3 * i + 1] = colour.g;
      pointColours[3 * i + 2] = colour.b;
    }
    pointGeometry.attributes.color.needsUpdate = true;
  }
  colourPoints('height');
  document.getElementById('colour-by').addEventListener('change', function (event) {
    colourPoints(event.target.value);
    render();
  });
  var pointLayer = new THREE.Group();
  pointLayer.add(new THREE.Points(pointGeometry, new THREE.PointsMaterial(
      {size: 0.018, vertexColors: THREE.VertexColors})));
  addLayer('points', 'points (' + data.points.count + ')', pointLayer, true);

  // The fitted CAD models' points, in their detection's class colour.
  var fittedLayer = new THREE.Group();
  if (data.fitted.count > 0) {
    var fittedPositions = positionsOf(data.fitted);
    var owners = decodeInt16(data.fitted.detection);
    var fittedColours = new Float32Array(fittedPositions.length);
    for (var f = 0; f < owners.length; ++f) {
      var c = new THREE.Color(data.colours[data.detections[owners[f]]['class']]);
      fittedColours[3 * f] = c.r;
      fittedColours[3 * f + 1] = c.g;
      fittedColours[3 * f + 2] = c.b;
    }
    var fittedGeometry = new THREE.BufferGeometry();
    fittedGeometry.setAttribute('position', new THREE.BufferAttribute(fittedPositions, 3));
    fittedGeometry.setAttribute('color', new THREE.BufferAttribute(fittedColours, 3));
    fittedLayer.add(new THREE.Points(fittedGeometry, new THREE.PointsMaterial(
        {size: 0.014, vertexColors: THREE.VertexColors})));
  }
  addLayer('fitted', 'fitted models (' + data.fitted.count + ' points)', fittedLayer, true);

  // A box: a faint solid to click, its edges, and a line from its centre to its front (+x).
  function boxMesh(box, colour, opacity, info) {
    var geometry = new THREE.BoxBufferGeometry(box.size[0], box.size[1], box.size[2]);
    var mesh = new THREE.Mesh(geometry, new THREE.MeshBasicMaterial(
        {color: colour, transparent: true, opacity: opacity, depthWrite: false}));
    mesh.position.set(box.centre[0], box.centre[1], box.centre[2]);
    mesh.rotation.z = box.yaw;
    mesh.add(new THREE.LineSegments(new THREE.EdgesGeometry(geometry),
                                    new THREE.LineBasicMaterial({color: colour})));
    var front = new THREE.BufferGeometry();
    var top = box.size[2] / 2;
    front.setAttribute('position', new THREE.BufferAttribute(
        new Float32Array([0, 0, top, box.size[0] / 2 + 0.15, 0, top]), 3));
    mesh.add(new THREE.Line(front, new THREE.LineBasicMaterial({color: colour})));
    mesh.userData.info = info;
    pickable.push(mesh);
    return mesh;
  }

  var truthLayer = new THREE.Group();
  data.truth.forEach(function (t) {
    var colour = t.missed ? 0xff5a4a : (t.target ? 0xffffff : 0x6a6a6a);
    var info = 'ground truth: ' + (t['class'] || 'clutter') + (t.model ? ' (' + t.model + ')' : '') +
        '\n' + t.fate + (t.visibility !== null ? '\nvisibility ' + t.visibility.toFixed(2) : '');
    truthLayer.add(boxMesh(t, colour, 0.06, info));
  });
  addLayer('truth', 'ground truth (' + data.truth.length + ')', truthLayer, true);

  var detectionLayer = new THREE.Group();
  data.detections.forEach(function (d) {
    var info = 'detection: ' + d['class'] + ', score ' + d.score.toFixed(3) +
        (d.model ? '\nmodel ' + d.model : '') + '\n' + d.fate +
        '\nbox ' + d.size.map(function (v) { return v.toFixed(2); }).join(' x ') + ' m, yaw ' +
        (d.yaw * 180 / Math.PI).toFixed(0) + ' deg';
    detectionLayer.add(boxMesh(d, new THREE.Color(data.colours[d['class']]), 0.16, info));
  });
  addLayer('detections', 'detections (' + data.detections.length + ')', detectionLayer, true);

  // Maxima (Hough votes or learned heat): spheres on the floor; grey when no detection.
  var maximaLayer = new THREE.Group();
  var sphere = new THREE.SphereBufferGeometry(0.045, 12, 8);
  data.maxima.forEach(function (m) {
    var colour = m.detected ? new THREE.Color(data.colours[m['class']]) : new THREE.Color(0x999999);
    var mesh = new THREE.Mesh(sphere, new THREE.MeshBasicMaterial({color: colour}));
    mesh.position.set(m.x, m.y, 0.05);
    mesh.userData.info = 'maximum: ' + m['class'] + ', value ' + m.value.toFixed(3) + '\n' +
        m.outcome;
    pickable.push(mesh);
    maximaLayer.add(mesh);
  });
  addLayer('maxima', 'maxima (' + data.maxima.length + ')', maximaLayer, true);

  // The learned heat as a texture on the floor (row 0 at the smallest y).
  var heatLayer = new THREE.Group();
  if (data.heat) {
    var text = atob(data.heat.rgba);
    var rgba = new Uint8Array(text.length);
    for (var h = 0; h < text.length; ++h) rgba[h] = text.charCodeAt(h);
    var texture = new THREE.DataTexture(rgba, data.heat.cols, data.heat.rows, THREE.RGBAFormat);
    texture.magFilter = THREE.NearestFilter;
    texture.needsUpdate = true;
    var width = data.heat.cols * data.heat.cell_m, depth = data.heat.rows * data.heat.cell_m;
    var plane = new THREE.Mesh(new THREE.PlaneBufferGeometry(width, depth),
                               new THREE.MeshBasicMaterial({map: texture, transparent: true,
                                                            depthWrite: false}));
    plane.position.set(data.heat.origin[0] + width / 2, data.heat.origin[1] + depth / 2, 0.004);
    heatLayer.add(plane);
  }
  addLayer('heat', data.heat ? 'learned heat' : 'learned heat (none: codebook run)', heatLayer,
           !!data.heat);

  // Floor grid every metre around the points and the sensor.
  var bounds = new THREE.Box3().setFromBufferAttribute(pointGeometry.attributes.position);
  var pose = data.camera.world_from_camera;
  var sensor = new THREE.Vector3(pose[0][3], pose[1][3], pose[2][3]);
  if (bounds.isEmpty()) bounds.set(sensor.clone(), sensor.clone());
  bounds.expandByPoint(sensor);
  var size = Math.ceil(Math.max(bounds.max.x - bounds.min.x, bounds.max.y - bounds.min.y)) + 2;
  var grid = new THREE.GridHelper(size, size, 0x666666, 0x3a3a3a);
  grid.rotation.x = Math.PI / 2;
  grid.position.set(Math.round((bounds.min.x + bounds.max.x) / 2),
                    Math.round((bounds.min.y + bounds.max.y) / 2), 0);
  var gridLayer = new THREE.Group();
  gridLayer.add(grid);
  gridLayer.add(new THREE.AxesHelper(0.5));
  addLayer('grid', 'floor grid (1 m) and world axes', gridLayer, true);

  // The camera: its position and the edges of its view to 0.5 m.
  var cameraLayer = new THREE.Group();
  var k = data.camera;
  function toWorld(x, y, z) {
    return new THREE.Vector3(pose[0][0] * x + pose[0][1] * y + pose[0][2] * z + pose[0][3],
                             pose[1][0] * x + pose[1][1] * y + pose[1][2] * z + pose[1][3],
                             pose[2][0] * x + pose[2][1] * y + pose[2][2] * z + pose[2][3]);
  }
  var corners = [[0, 0], [k.width, 0], [k.width, k.height], [0, k.height]].map(function (uv) {
    var z = 0.5;
    return toWorld((uv[0] - k.cx) / k.fx * z, (uv[1] - k.cy) / k.fy * z, z);
  });
  var frustum = [];
  corners.forEach(function (corner, i) {
    frustum.push(sensor, corner, corner, corners[(i + 1) % 4]);
  });
  var frustumGeometry = new THREE.BufferGeometry().setFromPoints(frustum);
  cameraLayer.add(new THREE.LineSegments(frustumGeometry,
                                         new THREE.LineBasicMaterial({color: 0xffffff})));
  addLayer('camera', 'camera', cameraLayer, true);

  // The first view: from behind and above the sensor, towards the points' middle.
  var middle = bounds.getCenter(new THREE.Vector3());
  middle.z = 0.4;
  var back = sensor.clone().sub(middle);
  back.z = 0;
  if (back.length() < 1e-3) back.set(-1, 0, 0);
  back.setLength(Math.max(1.5, 0.6 * back.length()));
  camera.position.copy(sensor).add(back).add(new THREE.Vector3(0, 0, 1.6));
  controls.target.copy(middle);
  controls.update();

  function resize() {
    var w = window.innerWidth, h = window.innerHeight;
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
    render();
  }
  function render() { renderer.render(scene, camera); }
  controls.addEventListener('change', render);
  window.addEventListener('resize', resize);

  // A click: what lies under the pointer (the nearest box or maximum).
  var raycaster = new THREE.Raycaster();
  function pick(x, y) {
    var rect = canvas.getBoundingClientRect();
    var pointer = new THREE.Vector2((x - rect.left) / rect.width * 2 - 1,
                                    -(y - rect.top) / rect.height * 2 + 1);
    raycaster.setFromCamera(pointer, camera);
    var visible = pickable.filter(function (o) { return o.parent.visible; });
    var hits = raycaster.intersectObjects(visible, false);
    var text = hits.length ? hits[0].object.userData.info : 'Nothing there.';
    document.getElementById('info').textContent = text;
    return text;
  }
  var down = null;
  canvas.addEventListener('pointerdown', function (e) { down = [e.clientX, e.clientY]; });
  canvas.addEventListener('pointerup', function (e) {
    if (down && Math.abs(e.clientX - down[0]) + Math.abs(e.clientY - down[1]) < 4)
      pick(e.clientX, e.clientY);
  });

  // Navigation through the run's frames.
  var nav = document.getElementById('nav');
  [['previous', '\u2190 previous frame'], ['index', 'report'], ['next', 'next frame \u2192']]
      .forEach(function (link) {
        if (!data.navigation[link[0]]) return;
        var a = document.createElement('a');
        a.href = data.navigation[link[0]];
        a.textContent = link[1];
        a.id = 'nav-' + link[0];
        nav.appendChild(a);
      });
  window.addEventListener('keydown', function (e) {
    if (e.key === 'n' && data.navigation.next) window.location.href = data.navigation.next;
    if (e.key === 'p' && data.navigation.previous) window.location.href = data.navigation.previous;
  });
  function several(n, one, many) { return n + ' ' + (n === 1 ? one : many); }
  document.getElementById('counts').textContent = several(counts.points, 'point', 'points') +
      ', ' + several(counts.detections, 'detection', 'detections') + ', ' +
      several(counts.truth, 'true object', 'true objects') + ', ' +
      several(counts.maxima, 'maximum', 'maxima');
  var legend = document.getElementById('legend');
  Object.keys(data.colours).forEach(function (name) {
    var span = document.createElement('span');
    var swatch = document.createElement('i');
    swatch.style.background = data.colours[name];
    span.appendChild(swatch);
    span.appendChild(document.createTextNode(name));
    legend.appendChild(span);
  });

  // Pixels that differ from the background (a layer's share of the picture).
  function drawnPixels() {
    render();
    var copy = document.createElement('canvas');
    copy.width = 160;
    copy.height = 120;
    var context = copy.getContext('2d');
    context.drawImage(canvas, 0, 0, copy.width, copy.height);
    var pixels = context.getImageData(0, 0, copy.width, copy.height).data, drawn = 0;
    for (var i = 0; i < pixels.length; i += 4) {
      if (Math.abs(pixels[i] - 0x15) + Math.abs(pixels[i + 1] - 0x17) +
          Math.abs(pixels[i + 2] - 0x1a) > 24) ++drawn;
    }
    return drawn;
  }

  function selfTest() {
    var result = {ready: true, load_ms: Math.round(performance.now()), counts: counts,
                  objects: {truth: truthLayer.children.length,
                            detections: detectionLayer.children.length,
                            maxima: maximaLayer.children.length,
                            heat: heatLayer.children.length},
                  webgl: !!renderer.getContext(), toggles: {}, drawn: {}};
    result.drawn.all = drawnPixels();
    Object.keys(layers).forEach(function (name) {
      setLayer(name, false);
      var hidden = !layers[name].visible && !document.getElementById('layer-' + name).checked;
      result.drawn['without_' + name] = drawnPixels();
      setLayer(name, true);
      result.toggles[name] = hidden && layers[name].visible;
    });
    if (data.detections.length) {  // a click on the first detection's centre says what it is
      var d = data.detections[0];
      setLayer('truth', false);
      setLayer('maxima', false);
      var at = new THREE.Vector3(d.centre[0], d.centre[1], d.centre[2]).project(camera);
      var rect = canvas.getBoundingClientRect();
      result.pick = pick(rect.left + (at.x + 1) / 2 * rect.width,
                         rect.top + (1 - at.y) / 2 * rect.height);
      setLayer('truth', true);
      setLayer('maxima', true);
    }
    result.errors = errors;
    var check = document.getElementById('scene-check');
    check.textContent = JSON.stringify(result);
    check.hidden = false;
  }

  function finishLoading() {
    render();
    window.furnScene = {layers: layers, setLayer: setLayer, pick: pick, counts: counts,
                        load_ms: performance.now()};
    if (window.location.hash === '#selftest') selfTest();
  }
  resize();
  finishLoading();
})();
