# Read by cpack for each generator: a .deb must install under /usr, since its unit file, conffile
# (/etc/loci) and maintainer scripts carry the paths configured with CMAKE_INSTALL_PREFIX.
if(CPACK_GENERATOR STREQUAL "DEB" AND NOT CPACK_PACKAGING_INSTALL_PREFIX STREQUAL "/usr")
  message(FATAL_ERROR "the loci .deb needs a build configured with -DCMAKE_INSTALL_PREFIX=/usr "
                      "(this one has ${CPACK_PACKAGING_INSTALL_PREFIX})")
endif()
