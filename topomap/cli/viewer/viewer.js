"use strict";
// The topomap viewer: the map, its regions, doors and routes on one canvas. Everything it
// shows is in the JSON of #topomap-data (written by topomap/cli/viewer.py); map-frame metres.
(function () {
  const data = JSON.parse(document.getElementById("topomap-data").textContent);
  const canvas = document.getElementById("map");
  const ctx = canvas.getContext("2d");
  const tooltip = document.getElementById("tooltip");
  const routeBox = document.getElementById("route");
  const list = document.getElementById("regions");
  const byId = new Map(data.regions.map((r) => [r.id, r]));
  const NAME_FONT = "bold 13px system-ui, sans-serif";
  const view = { scale: 1, cx: 0, cy: 0, width: 0, height: 0 };
  const state = { hover: null, selected: [], route: null, path: null, pathSource: null,
    pathLength: null, drawnNames: [] };

  for (const region of data.regions) {
    let box = [Infinity, Infinity, -Infinity, -Infinity];
    for (const ring of region.rings) {
      for (const [x, y] of ring) {
        box = [Math.min(box[0], x), Math.min(box[1], y), Math.max(box[2], x), Math.max(box[3], y)];
      }
    }
    region.box = box;
  }

  function toScreen(x, y) {
    return [(x - view.cx) * view.scale + view.width / 2, view.height / 2 - (y - view.cy) * view.scale];
  }

  function toWorld(px, py) {
    return [(px - view.width / 2) / view.scale + view.cx, view.cy - (py - view.height / 2) / view.scale];
  }

  function inside(rings, x, y) { // even-odd over every ring: holes excluded
    let odd = false;
    for (const ring of rings) {
      for (let i = 0, j = ring.length - 1; i < ring.length; j = i++) {
        const [xi, yi] = ring[i];
        const [xj, yj] = ring[j];
        if ((yi > y) !== (yj > y) && x < ((xj - xi) * (y - yi)) / (yj - yi) + xi) odd = !odd;
      }
    }
    return odd;
  }

  function regionAt(x, y) {
    for (const r of data.regions) {
      const b = r.box;
      if (x >= b[0] && x <= b[2] && y >= b[1] && y <= b[3] && inside(r.rings, x, y)) return r;
    }
    return null;
  }

  function fit() {
    const [x0, y0, x1, y1] = data.bounds;
    const free = Math.max(200, view.width - 290); // room left of the panel
    view.scale = 0.95 * Math.min(free / (x1 - x0), view.height / (y1 - y0));
    view.cx = (x0 + x1) / 2 + (view.width - free) / 2 / view.scale;
    view.cy = (y0 + y1) / 2;
  }

  function resize() {
    const ratio = window.devicePixelRatio || 1;
    view.width = window.innerWidth;
    view.height = window.innerHeight;
    canvas.width = Math.round(view.width * ratio);
    canvas.height = Math.round(view.height * ratio);
  }

  const image = new Image();
  image.onload = () => draw();
  image.src = data.image;

  function polyline(points, colour, width) {
    if (points.length < 2) return;
    ctx.beginPath();
    points.forEach(([x, y], k) => {
      const [sx, sy] = toScreen(x, y);
      if (k === 0) ctx.moveTo(sx, sy); else ctx.lineTo(sx, sy);
    });
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.stroke();
  }

  function outline(region, colour, width) {
    for (const ring of region.rings) polyline(ring, colour, width);
  }

  function drawMap() {
    const [ox, oy, yaw] = data.origin;
    const cell = data.resolution;
    ctx.save();
    ctx.translate(view.width / 2 - view.cx * view.scale, view.height / 2 + view.cy * view.scale);
    ctx.scale(view.scale, -view.scale); // world metres, y up
    ctx.translate(ox, oy);
    ctx.rotate(yaw);
    ctx.translate(0, data.height * cell);
    ctx.scale(data.image_step * cell, -data.image_step * cell); // image pixels, row 0 on top
    ctx.imageSmoothingEnabled = false;
    if (image.complete && image.naturalWidth) ctx.drawImage(image, 0, 0);
    ctx.restore();
  }

  function drawNames() {
    ctx.font = NAME_FONT;
    ctx.textAlign = "center";
    ctx.textBaseline = "middle";
    ctx.lineJoin = "round";
    const kept = [];
    const shown = [];
    const first = new Set([...state.selected, state.hover && state.hover.id]);
    const order = [...data.regions].sort(
      (a, b) => (first.has(b.id) - first.has(a.id)) || (b.area - a.area));
    for (const region of order) {
      const [sx, sy] = toScreen(region.x, region.y);
      const w = ctx.measureText(region.name).width + 6;
      const box = [sx - w / 2, sy - 9, sx + w / 2, sy + 9];
      const clash = kept.some((k) => box[0] < k[2] && box[2] > k[0] && box[1] < k[3] && box[3] > k[1]);
      if (clash && !first.has(region.id)) continue; // never two names on top of each other
      kept.push(box);
      shown.push(region.name);
      ctx.lineWidth = 4;
      ctx.strokeStyle = "rgba(255,255,255,0.95)";
      ctx.strokeText(region.name, sx, sy);
      ctx.fillStyle = "#111";
      ctx.fillText(region.name, sx, sy);
    }
    state.drawnNames = shown;
  }

  function draw() {
    const ratio = canvas.width / view.width;
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx.fillStyle = "#bfbfbf";
    ctx.fillRect(0, 0, view.width, view.height);
    drawMap();
    for (const segment of data.segments) polyline(segment, "rgba(0,0,0,0.55)", 1);
    for (const door of data.doors) polyline(door, "#d42020", 3);
    if (state.hover) outline(state.hover, "#222", 2);
    for (const id of state.selected) outline(byId.get(id), "#0050d0", 3);
    if (state.route) polyline(routeLine(state.route), "rgba(0,80,208,0.8)", 2);
    if (state.path) polyline(state.path, "#0a8a2a", 4);
    for (const region of data.regions) {
      const [sx, sy] = toScreen(region.x, region.y);
      ctx.beginPath();
      ctx.arc(sx, sy, 3, 0, 2 * Math.PI);
      ctx.fillStyle = "#111";
      ctx.fill();
    }
    drawNames();
  }

  // ---------------------------------------------------------------- routes
  const neighbours = new Map(data.regions.map((r) => [r.id, []]));
  for (const e of data.edges) {
    neighbours.get(e.a).push([e.b, e.w, e]);
    neighbours.get(e.b).push([e.a, e.w, e]);
  }

  function shortestRoute(source, target) { // Dijkstra on the region graph
    const dist = new Map([[source, 0]]);
    const previous = new Map();
    const done = new Set();
    while (true) {
      let best = null;
      for (const [node, d] of dist) if (!done.has(node) && (best === null || d < dist.get(best))) best = node;
      if (best === null) return null;
      if (best === target) break;
      done.add(best);
      for (const [next, w, edge] of neighbours.get(best)) {
        const d = dist.get(best) + w;
        if (!dist.has(next) || d < dist.get(next)) { dist.set(next, d); previous.set(next, [best, edge]); }
      }
    }
    const route = [{ id: target }];
    while (route[0].id !== source) {
      const [before, edge] = previous.get(route[0].id);
      route[0].door = edge.door;
      route.unshift({ id: before });
    }
    return route;
  }

  function routeLine(route) {
    const points = [];
    route.forEach((step, k) => {
      if (k > 0) points.push(step.door);
      const r = byId.get(step.id);
      points.push([r.x, r.y]);
    });
    return points;
  }

  function plannedPath(a, b) {
    const key = a < b ? `${a}-${b}` : `${b}-${a}`;
    const found = data.paths[key];
    return found ? (a < b ? found : [...found].reverse()) : null;
  }

  function pathFor(route) {
    const a = route[0].id;
    const b = route[route.length - 1].id;
    if (data.every_pair) return [plannedPath(a, b), "planned"];
    const legs = [];
    for (let k = 1; k < route.length; k++) {
      const leg = plannedPath(route[k - 1].id, route[k].id);
      if (!leg) return [null, "none"];
      legs.push(...(legs.length ? leg.slice(1) : leg));
    }
    return [legs, "legs"];
  }

  function length(points) {
    let total = 0;
    for (let k = 1; k < points.length; k++) {
      total += Math.hypot(points[k][0] - points[k - 1][0], points[k][1] - points[k - 1][1]);
    }
    return total;
  }

  function select(region) {
    if (state.selected.length >= 2) state.selected = [];
    if (region && !state.selected.includes(region.id)) state.selected.push(region.id);
    state.route = state.path = state.pathSource = state.pathLength = null;
    if (state.selected.length === 2) {
      state.route = shortestRoute(...state.selected);
      if (state.route) [state.path, state.pathSource] = pathFor(state.route);
      if (!state.path) state.pathSource = "none";
      state.pathLength = state.path ? length(state.path) : null;
    }
    showRoute();
    for (const li of list.children) li.classList.toggle("selected", state.selected.includes(+li.dataset.id));
    draw();
  }

  function showRoute() {
    const names = state.selected.map((id) => byId.get(id).name);
    if (state.selected.length < 2) {
      routeBox.textContent = names.length ? `From ${names[0]}: click a second region.` : "No route yet: click two regions.";
    } else if (!state.route) {
      routeBox.textContent = `No route from ${names[0]} to ${names[1]}: the region graph does not join them.`;
    } else {
      const via = state.route.map((step) => byId.get(step.id).name).join(" → ");
      const how = { planned: "planned path", legs: "planned legs between neighbours", none: "no path planned" };
      const metres = state.pathLength === null ? "" : `: ${state.pathLength.toFixed(1)} m`;
      routeBox.textContent = `${via} · ${how[state.pathSource]}${metres}`;
    }
  }

  // ---------------------------------------------------------------- interaction
  function showTooltip(region, px, py) {
    if (!region) { tooltip.hidden = true; return; }
    tooltip.replaceChildren();
    const title = document.createElement("b");
    title.textContent = region.name;
    const about = document.createElement("div");
    about.textContent = `${region.label || "no label"} · ${region.area.toFixed(1)} m² · ${region.doors} doors`;
    const next = document.createElement("div");
    next.textContent = region.neighbours.length ? `to ${region.neighbours.join(", ")}` : "no neighbours";
    tooltip.append(title, about, next);
    tooltip.dataset.id = region.id;
    tooltip.hidden = false;
    tooltip.style.left = `${Math.min(px + 14, view.width - 330)}px`;
    tooltip.style.top = `${py + 14}px`;
  }

  let drag = null;
  canvas.addEventListener("mousedown", (event) => {
    drag = { x: event.clientX, y: event.clientY, cx: view.cx, cy: view.cy, moved: false };
  });
  window.addEventListener("mousemove", (event) => {
    if (drag) {
      const dx = event.clientX - drag.x;
      const dy = event.clientY - drag.y;
      if (Math.hypot(dx, dy) > 4) { drag.moved = true; canvas.classList.add("dragging"); }
      if (drag.moved) {
        view.cx = drag.cx - dx / view.scale;
        view.cy = drag.cy + dy / view.scale;
        draw();
        return;
      }
    }
    if (event.target !== canvas) return;
    const region = regionAt(...toWorld(event.clientX, event.clientY));
    showTooltip(region, event.clientX, event.clientY);
    if (region !== state.hover) { state.hover = region; draw(); }
  });
  window.addEventListener("mouseup", (event) => {
    const click = drag && !drag.moved && event.target === canvas;
    drag = null;
    canvas.classList.remove("dragging");
    if (click) select(regionAt(...toWorld(event.clientX, event.clientY)));
  });
  canvas.addEventListener("mouseleave", () => { tooltip.hidden = true; state.hover = null; draw(); });
  canvas.addEventListener("wheel", (event) => {
    event.preventDefault();
    const before = toWorld(event.clientX, event.clientY);
    const factor = Math.exp(-event.deltaY * 0.0015);
    view.scale = Math.min(Math.max(view.scale * factor, 0.05), 2000);
    const after = toWorld(event.clientX, event.clientY);
    view.cx += before[0] - after[0];
    view.cy += before[1] - after[1];
    draw();
  }, { passive: false });
  window.addEventListener("resize", () => { resize(); draw(); });

  const legend = document.getElementById("legend");
  for (const [label, colour] of Object.entries(data.colours)) {
    const item = document.createElement("span");
    const swatch = document.createElement("i");
    swatch.className = "swatch";
    swatch.style.background = colour;
    item.append(swatch, label || "no label");
    legend.append(item);
  }
  for (const region of data.regions) {
    const li = document.createElement("li");
    li.dataset.id = region.id;
    li.textContent = `${region.name} (${region.label || "no label"})`;
    li.addEventListener("click", () => select(region));
    list.append(li);
  }

  resize();
  fit();
  draw();
  window.topomap = { data, state, view, toScreen, toWorld, regionAt, select, draw };
})();
