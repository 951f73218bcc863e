// Builds the viewer into dist/ (index.html + viewer.js) with esbuild, and the modules the node
// tests import into build/node/. The shaders come from crates/isogrid-gpu/shaders: the virtual
// module `isogrid:shaders` holds, for each module of shaders/modules.txt, its files concatenated
// in the listed order, exactly as the native renderer composes them (`src/shaders.rs`).
import * as esbuild from 'esbuild';
import { readFileSync, mkdirSync, copyFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import { dirname, join } from 'node:path';

const here = dirname(fileURLToPath(import.meta.url));
export const SHADER_DIR = join(here, '..', 'crates', 'isogrid-gpu', 'shaders');

/** The modules of shaders/modules.txt: name → files, in order. */
export function shaderManifest() {
  const modules = {};
  for (const line of readFileSync(join(SHADER_DIR, 'modules.txt'), 'utf8').split('\n')) {
    const t = line.trim();
    if (!t || t.startsWith('#')) continue;
    const [name, files] = t.split(':');
    modules[name.trim()] = files.trim().split(/\s+/);
  }
  return modules;
}

/** Each module's source: its files concatenated, as `wgpu_util::module` concatenates the parts. */
export function shaderSources() {
  const out = {};
  for (const [name, files] of Object.entries(shaderManifest())) {
    out[name] = files.map((f) => readFileSync(join(SHADER_DIR, f), 'utf8')).join('');
  }
  return out;
}

const shaderPlugin = {
  name: 'isogrid-shaders',
  setup(build) {
    build.onResolve({ filter: /^isogrid:shaders$/ }, () => ({ path: 'shaders', namespace: 'isogrid' }));
    build.onLoad({ filter: /.*/, namespace: 'isogrid' }, () => ({
      contents: `export const SHADERS = ${JSON.stringify(shaderSources())};`,
      loader: 'js',
      watchFiles: [join(SHADER_DIR, 'modules.txt'), ...Object.values(shaderManifest()).flat().map((f) => join(SHADER_DIR, f))],
    }));
  },
};

/** How the browser's scripts are written: the viewer's bundle and the worker inside it. */
const BROWSER_OUTPUT = {
  target: 'es2022',
  // Not minifySyntax: it would turn the shader strings into template literals; the shader test
  // finds each module's source in the bundle as the manifest composes it.
  minifyWhitespace: true,
  minifyIdentifiers: true,
  charset: 'utf8',
  logLevel: 'warning',
};

/**
 * The virtual module `isogrid:packed-worker`: the packed rebuild's worker (src/packed-worker.ts)
 * bundled on its own as a classic script, as a string the viewer starts from a Blob URL.
 */
const packedWorkerPlugin = {
  name: 'isogrid-packed-worker',
  setup(build) {
    build.onResolve({ filter: /^isogrid:packed-worker$/ }, () => ({ path: 'packed-worker', namespace: 'isogrid-worker' }));
    build.onLoad({ filter: /.*/, namespace: 'isogrid-worker' }, async () => {
      const out = await esbuild.build({
        ...BROWSER_OUTPUT,
        entryPoints: [join(here, 'src', 'packed-worker.ts')],
        bundle: true,
        format: 'iife',
        write: false,
        metafile: true,
        // The metafile's input paths are relative to it.
        absWorkingDir: here,
      });
      return {
        contents: `export const PACKED_WORKER = ${JSON.stringify(out.outputFiles[0].text)};`,
        loader: 'js',
        watchFiles: Object.keys(out.metafile.inputs).map((f) => join(here, f)),
      };
    });
  },
};

/** Builds the viewer into `dist` (web/dist, which is committed: `isogrid serve` embeds it). */
export async function build(dist = join(here, 'dist')) {
  mkdirSync(dist, { recursive: true });
  await esbuild.build({
    ...BROWSER_OUTPUT,
    entryPoints: [join(here, 'src', 'main.ts')],
    bundle: true,
    format: 'esm',
    outfile: join(dist, 'viewer.js'),
    plugins: [shaderPlugin, packedWorkerPlugin],
    sourcemap: false,
  });
  copyFileSync(join(here, 'src', 'index.html'), join(dist, 'index.html'));
  // The node tests' view of the pure modules (no DOM, no WebGPU).
  await esbuild.build({
    entryPoints: ['cgc', 'camera', 'loader', 'crc32', 'colors', 'packed'].map((m) => join(here, 'src', `${m}.ts`)),
    bundle: true,
    format: 'esm',
    platform: 'node',
    splitting: true,
    outdir: join(here, 'build', 'node'),
    logLevel: 'warning',
  });
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  await build();
}
