// The explain page on a nested plan (docs/explain-data.md, `nested`): the
// levels, one per shared definition, and a picked ray's way through them,
// the placements it entered at each level, those on the path to its hit
// marked. Runs before app.js, which announces each pick with an
// `arbor-pick` event; on a flat page it does nothing.
const data = JSON.parse(document.getElementById('arbor-data').textContent);
const nested = data.instancing === 'nested' ? data.nested : null;

if (nested) {
  const $ = (id) => document.getElementById(id);
  const nodes = new Map(((data.scene_graph && data.scene_graph.nodes) || []).map((n) => [n.id, n]));
  const fmt = (x) => String(parseFloat(Number(x).toPrecision(5)));
  const vec = (v) => '(' + v.map(fmt).join(', ') + ')';
  const nodeName = (id) => (id === null || id === undefined ? '—' : `#${id} ${(nodes.get(id) || {}).label || ''}`.trim());
  const levelName = (d) => (d === nested.root ? `world (level ${d})` : `level ${d}`);
  const row = (cells, attrs = {}) => {
    const tr = document.createElement('tr');
    for (const [k, v] of Object.entries(attrs)) tr.setAttribute(k, v);
    for (const c of cells) {
      const td = document.createElement('td');
      td.textContent = c;
      tr.append(td);
    }
    return tr;
  };

  for (const id of ['view3d-panel', 'traversal-panel']) $(id).hidden = true;
  // No heatmaps on a nested page (they count the flat structures).
  for (const e of document.querySelectorAll('#picture-panel .image-controls')) e.hidden = true;
  const graphTitle = $('graph-title').querySelector('.muted');
  if (graphTitle) graphTitle.textContent = '— the DAG as loaded, each shared definition drawn once';
  for (const id of ['levels-panel', 'path-panel']) $(id).hidden = false;

  const counts = (data.scene_graph && data.scene_graph.counts) || {};
  $('levels-summary').textContent = `${nested.levels.length} levels (the world and each shared definition, built once), ` +
    `${nested.children} child placements in all, at most ${nested.depth} below the world, ${nested.accel} at every level ` +
    `(${nested.memory_bytes} bytes of structures)` + (counts.placements ? `; as placed: ${counts.placements} placements, ${counts.primitives} primitives.` : '.');
  const levelsBody = $('levels-table').querySelector('tbody');
  for (const l of nested.levels) {
    const places = l.places.map((p) => `${p.times}× ${levelName(p.definition)}${p.geometry_only ? ' (its geometry)' : ''}`).join(', ');
    const structure = `${l.structure.nodes} nodes, depth ${l.structure.max_depth}` +
      (l.geometry_structure ? `; geometry: ${l.geometry_structure.nodes} nodes` : '');
    levelsBody.append(row([levelName(l.definition), nodeName(l.graph_node), String(l.children), places || '—',
      String(l.primitives), l.box ? `${vec(l.box[0])} – ${vec(l.box[1])}` : 'empty', structure],
    { 'data-definition': String(l.definition) }));
  }

  // The graph nodes on the hit's path, outlined in the scene graph.
  function markGraph(ids) {
    for (const g of document.querySelectorAll('.graph-node.on-path')) g.classList.remove('on-path');
    for (const id of ids) {
      const g = document.querySelector(`.graph-node[data-id="${id}"]`);
      if (g) g.classList.add('on-path');
    }
  }

  function showPath(ray) {
    const p = ray.nested;
    const body = $('path-list').querySelector('tbody');
    body.replaceChildren();
    p.levels.forEach((l, i) => {
      const through = l.depth === 0 ? 'the world' : l.child === null
        ? `the own geometry of ${levelName(l.parent)}` : `child ${l.child} of ${levelName(l.parent)}`;
      const what = l.geometry ? 'its primitives tested' : 'its placements';
      const tr = row([String(i + 1), String(l.depth), levelName(l.definition) + (l.geometry ? ' · geometry' : ''), through,
        nodeName(l.graph_node), l.culled ? 'culled: misses its own box, or meets it only past the closest hit so far' : `enters its box at t = ${fmt(l.t)}; ${what}`],
      { 'data-depth': String(l.depth), 'data-definition': String(l.definition), 'data-on-path': String(l.on_hit_path) });
      if (l.on_hit_path) tr.classList.add('on-path');
      if (l.culled) tr.classList.add('culled');
      body.append(tr);
    });
    const more = p.left_out ? ` ${p.left_out} more levels reached are not listed.` : '';
    const work = `${p.entered} placements entered, ${p.counts.nodes} nodes visited, ${p.counts.tests} primitives tested`;
    $('path-summary').textContent = p.hit
      ? `Hit at t = ${fmt(p.hit.t)}, point ${vec(p.hit.point)}, through ${p.hit.path.length} items: ` +
        p.hit.definitions.map(levelName).join(' → ') + ` (${work}; the path is marked).` + more
      : `No hit (${work}).` + more;
    $('path-summary').dataset.hitT = p.hit ? String(p.hit.t) : '';
    markGraph(p.hit ? p.hit.graph_nodes.filter((id) => id !== null) : []);
  }

  document.addEventListener('arbor-pick', (e) => { if (e.detail && e.detail.nested) showPath(e.detail); });
}
