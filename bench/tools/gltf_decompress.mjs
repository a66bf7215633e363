// Bench helper: rewrites Draco-compressed GLBs as plain ones (float accessors, no
// extension), the input a user's glTF corpus mostly is. node gltf_decompress.mjs OUT IN...
import { NodeIO } from '@gltf-transform/core';
import { ALL_EXTENSIONS } from '@gltf-transform/extensions';
import draco3d from 'draco3dgltf';
import path from 'node:path';

const [out, ...inputs] = process.argv.slice(2);
const io = new NodeIO().registerExtensions(ALL_EXTENSIONS).registerDependencies({
  'draco3d.decoder': await draco3d.createDecoderModule(),
});
for (const input of inputs) {
  const doc = await io.read(input);
  for (const ext of doc.getRoot().listExtensionsUsed()) ext.dispose();
  await io.write(path.join(out, path.basename(input)), doc);
}
