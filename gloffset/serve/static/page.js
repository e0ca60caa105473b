// The page of `gloffset serve`: the offset tiles of a layer at the slider's distance, the
// input drawn over them from /shape, a globe toggle, a click showing the distance to the
// curves (/distance), and the view, layer and distance kept in the URL hash
// (#map=zoom/lat/lon&layer=NAME&d=127km&globe=1).
"use strict";

const BACKGROUND = "#f2efe9";
const FILL = "#3070c0";
const FILL_OPACITY = 0.6;

const $ = (id) => document.getElementById(id);
const state = { layer: null, value: 127, unit: "km", globe: false, view: null };

function readHash() {
  const h = new URLSearchParams(location.hash.replace(/^#/, ""));
  const view = (h.get("map") || "").split("/").map(Number);
  if (view.length === 3 && view.every(Number.isFinite)) state.view = view;
  if (h.get("layer")) state.layer = h.get("layer");
  const d = /^([0-9]+(?:\.[0-9]+)?)(km|m)$/.exec(h.get("d") || "");
  if (d) {
    state.value = Number(d[1]);
    state.unit = d[2];
  }
  state.globe = h.get("globe") === "1";
}

function distanceText() {
  return `${state.value}${state.unit}`;
}

function writeHash(map) {
  const c = map.getCenter();
  const view = `${map.getZoom().toFixed(2)}/${c.lat.toFixed(5)}/${c.lng.toFixed(5)}`;
  const h = new URLSearchParams({ map: view, layer: state.layer, d: distanceText() });
  if (state.globe) h.set("globe", "1");
  history.replaceState(null, "", "#" + h.toString().replace(/%2F/g, "/"));
}

function tileUrl() {
  const layer = encodeURIComponent(state.layer);
  return `${location.origin}/tiles/${layer}/${distanceText()}/{z}/{x}/{y}.png`;
}

function style() {
  return {
    version: 8,
    sources: {
      offset: { type: "raster", tiles: [tileUrl()], tileSize: 256, maxzoom: 22 },
      input: { type: "geojson", data: `/shape/${encodeURIComponent(state.layer)}.geojson` },
    },
    layers: [
      { id: "background", type: "background", paint: { "background-color": BACKGROUND } },
      {
        id: "offset",
        type: "raster",
        source: "offset",
        paint: { "raster-opacity": FILL_OPACITY, "raster-fade-duration": 0 },
      },
      {
        id: "input",
        type: "line",
        source: "input",
        paint: { "line-color": "#202020", "line-width": 1.2 },
      },
    ],
  };
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

function setDistance(map) {
  $("distance-text").textContent = state.value;
  map.getSource("offset").setTiles([tileUrl()]);
  writeHash(map);
}

function wire(map) {
  let pending = null;
  $("distance").addEventListener("input", () => {
    state.value = Number($("distance").value);
    clearTimeout(pending);
    pending = setTimeout(() => setDistance(map), 60);
  });
  $("unit").addEventListener("change", () => {
    state.unit = $("unit").value;
    setDistance(map);
  });
  $("globe").addEventListener("change", () => {
    state.globe = $("globe").checked;
    map.setProjection({ type: state.globe ? "globe" : "mercator" });
    writeHash(map);
  });
  $("layer").addEventListener("change", () => {
    state.layer = $("layer").value;
    map.setStyle(style());
    writeHash(map);
  });
  map.on("moveend", () => writeHash(map));
  map.on("click", (e) => showDistance(map, e.lngLat));
}

async function start() {
  readHash();
  const layers = await (await fetch("/layers")).json();
  const names = layers.map((l) => l.name);
  if (!names.includes(state.layer)) state.layer = names[0];
  for (const n of names) $("layer").add(new Option(n, n, false, n === state.layer));
  $("distance").value = state.value;
  $("distance-text").textContent = state.value;
  $("unit").value = state.unit;
  $("globe").checked = state.globe;
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
  map.on("style.load", () => {
    map.setProjection({ type: state.globe ? "globe" : "mercator" });
  });
  wire(map);
  map.once("load", () => writeHash(map));
  window.gloffsetPage = { map, state, distanceText, FILL, BACKGROUND, FILL_OPACITY };
}

start();
