# Every dependency is a Debian 12 package (scripts/install-deps.sh installs them).
# Used both by our own build and by consumers of the installed package, so it
# must only find things, never define targets of ours.
include(CMakeFindDependencyMacro)
find_package(PkgConfig REQUIRED)
find_package(SQLite3 3.40 REQUIRED)
find_package(nlohmann_json 3.11 REQUIRED)
# OpenImageIO via pkg-config: Debian 12's CMake config names files from other packages
# (/usr/bin/iconvert, /usr/include/opencv4) and fails without them.
if(NOT TARGET PkgConfig::OIIO)
  pkg_check_modules(OIIO REQUIRED IMPORTED_TARGET OpenImageIO>=2.4)
endif()
find_package(fmt 9 REQUIRED)
if(NOT TARGET PkgConfig::XXHASH)
  pkg_check_modules(XXHASH REQUIRED IMPORTED_TARGET libxxhash>=0.8)
endif()
# PNG encoding (formats/png_encoder.cpp): Debian 12's libdeflate ships no CMake config.
if(NOT TARGET PkgConfig::LIBDEFLATE)
  pkg_check_modules(LIBDEFLATE REQUIRED IMPORTED_TARGET libdeflate>=1.14)
endif()
# solid::export writes the reference's zarr store with Blosc (export/zarr.cpp): Debian 12's
# c-blosc ships no CMake config.
if(NOT TARGET PkgConfig::BLOSC)
  pkg_check_modules(BLOSC REQUIRED IMPORTED_TARGET blosc>=1.21)
endif()
find_package(Threads REQUIRED)
find_package(draco 1.5 CONFIG REQUIRED)
# solid::convert: meshoptimizer decodes EXT_meshopt_compression of glTF input.
find_package(meshoptimizer 0.18 CONFIG REQUIRED)
# solid::convert reads third-party glTF/GLB input with tinygltf (convert/gltf_reader.cpp). Our
# own Draco GLBs are read and written by formats/glb.cpp, not by tinygltf (docs/dependencies.md
# says why).
find_package(TinyGLTF 2.7 CONFIG REQUIRED)
# solid::render
find_package(embree 3.13 CONFIG REQUIRED)
# solid::optimizer, through NLopt's C API (nlopt.h of libnlopt-dev; not the C++ wrapper)
find_package(NLopt 2.7 CONFIG REQUIRED)
# solid::optimizer: the local model's least squares (optimizer/local_model.cpp); header-only
find_package(Eigen3 3.3 CONFIG REQUIRED)
