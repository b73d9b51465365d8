// Keyboard shortcuts (listed in the help overlay, index.html). Keys typed into a form field are
// left to the field.
import { FEATURE_SCALE_STEPS, nearestStep } from './state.js';
const ORBIT_STEP_DEG = 5;
const ZOOM_STEP = 1.15;
const LAYOUT_KEYS = { 0: 'quad', 1: '3d', 2: 'xy', 3: 'xz', 4: 'yz' };

export function bindKeyboard(viewer) {
  const actions = keyActions(viewer);
  document.addEventListener('keydown', (event) => {
    if (event.ctrlKey || event.metaKey || event.altKey) return;
    if (isTyping(event.target)) return;
    const action = actions[event.key] ?? actions[event.key.toLowerCase()];
    if (!action) return;
    event.preventDefault();
    action(event);
  });
}

function isTyping(target) {
  const tag = target?.tagName;
  if (tag === 'TEXTAREA' || tag === 'SELECT') return true;
  return tag === 'INPUT' && !['checkbox', 'color', 'button'].includes(target.type);
}

function keyActions(viewer) {
  const state = () => viewer.state;
  const orbit = (daz, del) => () => {
    if (!viewer.dataset3d()) return;
    const camera = state().camera;
    camera.az = (((camera.az + daz) % 360) + 360) % 360;
    camera.el = Math.max(-90, Math.min(90, camera.el + del));
    viewer.changed({ camera: true, interactive: true });
  };
  const zoom = (factor) => () => viewer.dataset3d() && viewer.view3d.zoom(factor);
  const rank = (delta) => () => {
    const max = viewer.scalarDataset()?.rank ?? 0;
    if (state().rank > 0) viewer.setRender({ rank: Math.max(1, Math.min(max, state().rank + delta)) }, false);
  };
  const featureScale = (delta) => () => {
    if ((viewer.scalarDataset()?.feature_scale_ladder ?? []).length === 0) return;
    const i = nearestStep(FEATURE_SCALE_STEPS, state().featureScale) + delta;
    viewer.setRender({ featureScale: FEATURE_SCALE_STEPS[Math.max(0, Math.min(FEATURE_SCALE_STEPS.length - 1, i))] }, false);
  };
  const slice = (steps) => () => (viewer.activeSlice ?? viewer.slices[0]).step(steps);
  const actions = {
    '?': () => viewer.toggleHelp(),
    Escape: () => viewer.toggleHelp(false),
    ArrowLeft: orbit(ORBIT_STEP_DEG, 0),
    ArrowRight: orbit(-ORBIT_STEP_DEG, 0),
    ArrowUp: orbit(0, ORBIT_STEP_DEG),
    ArrowDown: orbit(0, -ORBIT_STEP_DEG),
    '+': zoom(1 / ZOOM_STEP),
    '=': zoom(1 / ZOOM_STEP),
    '-': zoom(ZOOM_STEP),
    r: () => viewer.dataset3d() && viewer.view3d.resetCamera(),
    x: () => viewer.dataset3d() && viewer.view3d.alignTo('x'),
    y: () => viewer.dataset3d() && viewer.view3d.alignTo('y'),
    z: () => viewer.dataset3d() && viewer.view3d.alignTo('z'),
    t: () => viewer.setSource3d(state().source3d === 'labels' ? 'scalar' : 'labels'),
    o: () => {
      viewer.view3d.showOverlay = !viewer.view3d.showOverlay;
      viewer.view3d.drawOverlay();
    },
    '[': rank(-1),
    ']': rank(1),
    '{': featureScale(-1),
    '}': featureScale(1),
    s: () => viewer.setRender({ shading: !state().shading }, false),
    v: () => viewer.setLayerVisible('scalar', !state().scalarVisible),
    l: () => viewer.setLayerVisible('labels', !state().labelsVisible),
    c: () => {
      const reference = viewer.referenceDataset();
      if (reference) viewer.setCursor(reference.dims.map((d) => Math.floor(d / 2)));
    },
    PageUp: slice(1),
    PageDown: slice(-1),
    q: () => viewer.query.run(),
    p: () => viewer.screenshot(),
  };
  for (const [key, layout] of Object.entries(LAYOUT_KEYS)) actions[key] = () => viewer.setLayout(layout);
  return actions;
}
