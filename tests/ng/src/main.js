// The stock Neuroglancer viewer, its state read from the URL fragment (#!{json}), as
// Neuroglancer's own site sets it up. setupDefaultViewer also sets window.viewer, which the
// test reads (viewer.isReady(), viewer.state).
import 'neuroglancer';
import { setupDefaultViewer } from 'neuroglancer/unstable/ui/default_viewer_setup.js';

setupDefaultViewer();
