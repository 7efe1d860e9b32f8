# `cmake --preset package && cmake --build --preset package && cpack --config
# build/package/CPackConfig.cmake` builds build/package/dco_<version>_<arch>.deb: dcod with its unit,
# sysusers.d, tmpfiles.d, udev rule and /etc/dcod/dcod.toml (a conffile), the client library,
# its headers, dco-watch, dco-compositor and dco-diag (reports of field logs). Dependencies come from dpkg-shlibdeps.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME dco)
set(CPACK_PACKAGE_VENDOR dco)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Dense, contour-accurate stereo depth for mixed-reality headsets")
set(CPACK_PACKAGE_CONTACT "dco maintainers <maintainers@dco.invalid>")
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
set(CPACK_SET_DESTDIR ON)  # /etc/dcod/dcod.toml is installed outside the prefix
# In the build tree whatever directory cpack runs from (else the .deb and CPack's staging land
# in the current directory, the source tree when run as documented). `cpack -B DIR` overrides.
set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR})
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/systemd/debian/postinst ${PROJECT_BINARY_DIR}/systemd/debian/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
