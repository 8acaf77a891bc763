# Debian package: `cpack -G DEB` in a build folder (after building) writes
# handsteady_<version>_<arch>.deb holding everything `cmake --install` installs, under
# /usr: the layer builds in <libdir>/handsteady, the layer manifests in
# share/openxr/1/api_layers/{explicit,implicit}.d (where the Khronos loader looks), the
# shipped model in share/handsteady/models, the CLI (and the demo, when built) in bin, and
# the replay runtime with its manifest in share/handsteady (never made the active
# runtime). The paths between these are relative (manifest -> layer -> model), so the
# package also works unpacked under another root: tests/package checks it that way.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME handsteady)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(HS_PACKAGE_CONTACT "HandSteady maintainers <maintainers@users.noreply.h-seed-b1526014.example>"
    CACHE STRING "Maintainer of the Debian package")
set(CPACK_PACKAGE_CONTACT ${HS_PACKAGE_CONTACT})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "OpenXR API layer that denoises and predicts hand-tracking joints")
# Lines under 80 characters, as Debian's description format wants.
set(CPACK_PACKAGE_DESCRIPTION
    "XR_APILAYER_NOVENDOR_handsteady filters the joints of XR_EXT_hand_tracking\n"
    "between any OpenXR app and runtime: a shipped Multi-STGAE model, One Euro,\n"
    "DESP or Kalman. Also the handsteady CLI (filter, evaluate and synthesise hand\n"
    "tracks) and a headless replay runtime for testing without a headset.")
string(REPLACE ";" "" CPACK_PACKAGE_DESCRIPTION "${CPACK_PACKAGE_DESCRIPTION}")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION graphics)  # as Debian's own OpenXR layers
# Depends from the linked libraries (dpkg-shlibdeps). A build with libtorch (training) or
# the demo adds their libraries: configure with -DHS_BUILD_TRAINING=OFF -DHS_BUILD_DEMO=OFF
# for a package with the layer's few dependencies.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The layer is loaded by the loader but never links it (apps may bring their own loader,
# and Debian's layer packages do not depend on it either): recommended, which apt installs.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS libopenxr-loader1)
# Stripped: smaller, and no debug information naming the build's folders.
set(CPACK_STRIP_FILES ON)
include(CPack)
