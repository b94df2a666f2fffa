// The one translation unit that compiles tinygltf and stb_image / stb_image_write. Everything else
// includes the headers without the *_IMPLEMENTATION defines. Compiled with -w (third-party code).
#define TINYGLTF_IMPLEMENTATION
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
// We model no textures (docs/ARCHITECTURE.md, "Contracts"): never read image files referenced by a
// glTF; the loader also installs a no-op image callback so embedded images are not decoded either.
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>
