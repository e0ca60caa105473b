// The page of `gloffset serve`: the offset region of a layer at the slider's distance
// (inward, d < 0, included) in km, m, mi or nmi, the input drawn over it from /shape, a globe
// toggle, a legend, a click showing the distance to the curves (/distance), and the view,
// layer, distance and projection kept in the URL hash
// (#map=zoom/lat/lon&layer=NAME&d=-127km&globe=1), followed when it changes.
//
// How the region is drawn is a mode (#mode=field or #mode=exact, the "exact tiles" toggle):
// - MODES.field (the default where the server has field tiles): a raster-dem source of the
//   distance-field tiles (/field/LAYER/z/x/y.png, the signed distance in metres in the
//   custom encoding that /field/LAYER.json gives) drawn by a color-relief layer whose
//   colour ramp goes from the fill at d - 1 m to transparent at d. A new distance is a new
//   ramp (a paint property): the browser's GPU redraws the region with no request. (The
//   ramp must be an `interpolate`: a `step` expression draws nothing.)
// - MODES.exact shows the server's exact tiles (/tiles/LAYER/DIST/z/x/y.png, one request
//   a tile and distance): gloffset.render(shape, d, Tile(z, x, y)) for each tile.
// - MODES.vector (#mode=vector, the "vector tiles" toggle): the server's Mapbox Vector
//   Tiles of the region's exact boundary (/mvt/LAYER/z/x/y.pbf?d=DIST, one layer named
//   after the input), drawn by a fill and an outline layer styled here; crisp at any zoom
//   and on the globe.
// A mode gives the sources and layers it adds to the style and what a new distance does
// to them. window.gloffsetMap is the MapLibre map, window.gloffsetPage the page's state.
"use strict";

const BACKGROUND = "#f2efe9";
const FILL = "#3070c0";
const FILL_OPACITY = 0.6;
const INPUT_COLOUR = "#202020";
const OUTLINE = "#1d4f8c";

// each unit: metres in one, the slider's reach (-max..+max) and step
const UNITS = {
  km: { metres: 1000, max: 5000, step: 1 },
  m: { metres: 1, max: 20000, step: 10 },
  mi: { metres: 1609.344, max: 3000, step: 1 },
  nmi: { metres: 1852, max: 2700, step: 1 },
};
const DISTANCE = /^(-?[0-9]+(?:\.[0-9]+)?)(km|m|mi|nmi)$/;

const $ = (id) => document.getElementById(id);
const state = {
  layer: null,
  names: [],
  value: 127,
  unit: "km",
  globe: false,
  view: null,
  mode: null, // "field", "exact" or "vector"; null: field where the server has field tiles
  encoding: null, // the field tiles' custom encoding (/field/LAYER.json), null: none
};

// ------------------------------------------------------------------ the URL hash
function parseHash() {
  const h = new URLSearchParams(location.hash.replace(/^#/, ""));
  const out = { globe: h.get("globe") === "1" };
  const view = (h.get("map") || "").split("/").map(Number);
  if (view.length === 3 && view.every(Number.isFinite)) out.view = view;
  if (h.get("layer")) out.layer = h.get("layer");
  if (MODES[h.get("mode")]) out.mode = h.get("mode");
  const d = DISTANCE.exec(h.get("d") || "");
  if (d) {
    out.unit = d[2];
    out.value = Number(d[1]); // beyond the slider's reach, the slider stops at its end
  }
  return out;
}

function writeHash(map) {
  const c = map.getCenter();
  const view = `${map.getZoom().toFixed(2)}/${c.lat.toFixed(5)}/${c.lng.toFixed(5)}`;
  const h = new URLSearchParams({ map: view, layer: state.layer, d: distanceText() });
  if (state.globe) h.set("globe", "1");
  if (state.mode === "exact" || state.mode === "vector") h.set("mode", state.mode);
  history.replaceState(null, "", "#" + h.toString().replace(/%2F/g, "/"));
}

// ------------------------------------------------------------------ distances
function clampValue(value, unit) {
  const u = UNITS[unit];
  return Math.max(-u.max, Math.min(u.max, value));
}

function distanceText() {
  return `${state.value}${state.unit}`;
}

function distanceMetres() {
  return state.value * UNITS[state.unit].metres;
}

function describeDistance() {
  return `${state.value} ${state.unit}`;
}

// ------------------------------------------------------------------ modes
function tileUrl() {
  const layer = encodeURIComponent(state.layer);
  return `${location.origin}/tiles/${layer}/${distanceText()}/{z}/{x}/{y}.png`;
}

function mvtUrl() {
  const layer = encodeURIComponent(state.layer);
  return `${location.origin}/mvt/${layer}/{z}/{x}/{y}.pbf?d=${distanceText()}`;
}

function fieldUrl() {
  return `${location.origin}/field/${encodeURIComponent(state.layer)}/{z}/{x}/{y}.png`;
}

// the colour of a signed distance v (metres): the fill where v <= d - 1 m, transparent
// from d on (an interpolate: a step expression draws nothing)
function ramp() {
  const d = distanceMetres();
  return ["interpolate", ["linear"], ["elevation"], d - 1, FILL, d, "rgba(0, 0, 0, 0)"];
}

const MODES = {
  // the field tiles, thresholded at d by the browser
  field: {
    sources: () => ({
      offset: {
        type: "raster-dem",
        tiles: [fieldUrl()],
        tileSize: 256,
        maxzoom: 22,
        encoding: "custom",
        ...state.encoding,
      },
    }),
    layers: () => [
      {
        id: "offset",
        type: "color-relief",
        source: "offset",
        paint: { "color-relief-color": ramp(), "color-relief-opacity": FILL_OPACITY },
      },
    ],
    setDistance: (map) => map.setPaintProperty("offset", "color-relief-color", ramp()),
  },
  // the server's exact tiles: gloffset.render(shape, d, Tile(z, x, y)) for each tile
  exact: {
    sources: () => ({
      offset: { type: "raster", tiles: [tileUrl()], tileSize: 256, maxzoom: 22 },
    }),
    layers: () => [
      {
        id: "offset",
        type: "raster",
        source: "offset",
        paint: { "raster-opacity": FILL_OPACITY, "raster-fade-duration": 0 },
      },
    ],
    setDistance: (map) => map.getSource("offset").setTiles([tileUrl()]),
  },
  // the server's vector tiles of the exact boundary, filled and outlined here
  vector: {
    sources: () => ({
      offset: { type: "vector", tiles: [mvtUrl()], maxzoom: 16 },
    }),
    layers: () => [
      {
        id: "offset",
        type: "fill",
        source: "offset",
        "source-layer": state.layer,
        paint: { "fill-color": FILL, "fill-opacity": FILL_OPACITY, "fill-antialias": false },
      },
      {
        id: "offset-outline",
        type: "line",
        source: "offset",
        "source-layer": state.layer,
        paint: { "line-color": OUTLINE, "line-width": 1.5 },
      },
    ],
    setDistance: (map) => map.getSource("offset").setTiles([mvtUrl()]),
  },
};

function style() {
  const mode = MODES[state.mode];
  const input = { type: "geojson", data: `/shape/${encodeURIComponent(state.layer)}.geojson` };
  return {
    version: 8,
    sources: { ...mode.sources(), input },
    layers: [
      { id: "background", type: "background", paint: { "background-color": BACKGROUND } },
      ...mode.layers(),
      {
        id: "input",
        type: "line",
        source: "input",
        paint: { "line-color": INPUT_COLOUR, "line-width": 1.2 },
      },
    ],
  };
}

// ------------------------------------------------------------------ the panel
function showControls() {
  const u = UNITS[state.unit];
  const slider = $("distance");
  slider.min = -u.max;
  slider.max = u.max;
  slider.step = u.step;
  slider.value = state.value;
  $("unit").value = state.unit;
  $("distance-text").textContent = describeDistance();
  $("globe").checked = state.globe;
  $("exact").checked = state.mode === "exact";
  $("vector").checked = state.mode === "vector";
  $("layer").value = state.layer;
  showLegend();
}

function showLegend() {
  const d = describeDistance();
  $("legend-region").textContent =
    state.value < 0
      ? `inside the polygons, farther than ${d.replace(/^-/, "")} from their boundary`
      : `within ${d} of the curves (polygons included)`;
  $("legend-distance").textContent = `d = ${d}`;
}

// the colour of `top` drawn at opacity `a` over `bottom` (#rrggbb), as the map shows it
function mix(top, bottom, a) {
  const rgb = (h) => [1, 3, 5].map((i) => parseInt(h.slice(i, i + 2), 16));
  const [t, b] = [rgb(top), rgb(bottom)];
  return `rgb(${t.map((v, i) => Math.round(a * v + (1 - a) * b[i])).join(", ")})`;
}

function showDistance(map, lngLat) {
  const layer = encodeURIComponent(state.layer);
  const url = `/distance/${layer}?lon=${lngLat.lng.toFixed(6)}&lat=${lngLat.lat.toFixed(6)}`;
  fetch(url)
    .then((r) => r.json())
    .then((body) => {
      const text =
        body.distance_m === undefined
          ? body.detail
          : `${(body.distance_m / 1000).toFixed(3)} km from the curves` +
            (body.inside ? " (inside)" : "");
      $("info").textContent = text;
      new maplibregl.Popup({ closeButton: true }).setLngLat(lngLat).setText(text).addTo(map);
    });
}

// ------------------------------------------------------------------ changes
function setDistance(map) {
  showControls();
  if (map.getSource("offset")) MODES[state.mode].setDistance(map);
  writeHash(map);
}

function setUnit(map, unit) {
  // the same distance in the new unit, on the slider's steps and within its reach
  const u = UNITS[unit];
  const value = Math.round(distanceMetres() / u.metres / u.step) * u.step;
  state.unit = unit;
  state.value = clampValue(value, unit);
  setDistance(map);
}

function setProjection(map) {
  map.setProjection({ type: state.globe ? "globe" : "mercator" });
}

function followHash(map) {
  const h = parseHash();
  if (h.view) {
    const c = map.getCenter();
    const [zoom, lat, lon] = h.view;
    const moved =
      Math.abs(map.getZoom() - zoom) > 0.005 ||
      Math.abs(c.lat - lat) > 1e-5 ||
      Math.abs(c.lng - lon) > 1e-5;
    if (moved) map.jumpTo({ zoom, center: [lon, lat] });
  }
  if (h.unit !== undefined) {
    state.unit = h.unit;
    state.value = h.value;
  }
  if (h.globe !== state.globe) {
    state.globe = h.globe;
    setProjection(map);
  }
  const mode = h.mode || defaultMode();
  const layer = h.layer && state.names.includes(h.layer) ? h.layer : state.layer;
  if (layer !== state.layer || mode !== state.mode) {
    state.layer = layer;
    state.mode = mode;
    map.setStyle(style()); // its sources at the new distance
    showControls();
    writeHash(map);
  } else {
    setDistance(map);
  }
}

function wire(map) {
  let pending = null;
  $("distance").addEventListener("input", () => {
    state.value = Number($("distance").value);
    showControls();
    clearTimeout(pending);
    // a field is redrawn at once; exact tiles wait until the slider rests
    if (state.mode === "field") setDistance(map);
    else pending = setTimeout(() => setDistance(map), 60);
  });
  $("unit").addEventListener("change", () => setUnit(map, $("unit").value));
  for (const [id, mode] of [
    ["exact", "exact"],
    ["vector", "vector"],
  ]) {
    $(id).addEventListener("change", () => {
      state.mode = $(id).checked ? mode : defaultMode();
      map.setStyle(style());
      showControls();
      writeHash(map);
    });
  }
  $("globe").addEventListener("change", () => {
    state.globe = $("globe").checked;
    setProjection(map);
    writeHash(map);
  });
  $("layer").addEventListener("change", () => {
    state.layer = $("layer").value;
    map.setStyle(style());
    writeHash(map);
  });
  window.addEventListener("hashchange", () => followHash(map));
  map.on("moveend", () => writeHash(map));
  map.on("click", (e) => showDistance(map, e.lngLat));
}

// ------------------------------------------------------------------ start
function defaultMode() {
  return state.encoding ? "field" : "exact";
}

// the custom encoding of the layer's field tiles, or null where the server has none
async function fieldEncoding(layer) {
  try {
    const r = await fetch(`/field/${encodeURIComponent(layer)}.json`);
    return r.ok ? (await r.json()).encoding || null : null;
  } catch (e) {
    return null;
  }
}

async function start() {
  Object.assign(state, parseHash());
  const layers = await (await fetch("/layers")).json();
  const names = (state.names = layers.map((l) => l.name));
  if (!names.includes(state.layer)) state.layer = names[0];
  state.encoding = await fieldEncoding(state.layer); // one encoding for every layer
  if (!state.mode || (state.mode === "field" && !state.encoding)) state.mode = defaultMode();
  for (const n of names) $("layer").add(new Option(n, n, false, n === state.layer));
  for (const u of Object.keys(UNITS)) $("unit").add(new Option(u, u));
  $("legend-fill").style.background = mix(FILL, BACKGROUND, FILL_OPACITY);
  $("legend-outside").style.background = BACKGROUND;
  $("legend-input").style.borderTopColor = INPUT_COLOUR;
  showControls();
  const info = layers.find((l) => l.name === state.layer);
  const opts = { container: "map", style: style(), attributionControl: false };
  if (state.view) {
    opts.zoom = state.view[0];
    opts.center = [state.view[2], state.view[1]];
  } else {
    opts.bounds = info.bounds;
    opts.fitBoundsOptions = { padding: 40 };
  }
  const map = new maplibregl.Map(opts);
  map.on("style.load", () => setProjection(map));
  wire(map);
  map.once("load", () => writeHash(map));
  window.gloffsetMap = map;
  window.gloffsetPage = {
    map,
    state,
    MODES,
    UNITS,
    distanceText,
    distanceMetres,
    FILL,
    OUTLINE,
    BACKGROUND,
    FILL_OPACITY,
  };
}

start();
