// Bundles Neuroglancer (the npm package, version pinned in package-lock.json) into dist/ for
// neuroglancer.test.mjs; the same settings as Neuroglancer's own examples/vite project.
import { defineConfig } from 'vite';

export default defineConfig({
  // Relative URLs: dist/ is served from any path by the test's static server.
  base: '',
  logLevel: 'warn',
  resolve: {
    // Only the precomputed data source: the one the test reads.
    conditions: ['neuroglancer/datasource:none_by_default', 'neuroglancer/datasource/precomputed:enabled'],
  },
  // Neuroglancer's workers use dynamic imports.
  worker: { format: 'es' },
  build: {
    outDir: 'dist',
    emptyOutDir: true,
    chunkSizeWarningLimit: 4 * 1024 * 1024,
  },
});
