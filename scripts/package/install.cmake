# `cmake --install` and the Debian package (issue 26, docs/install.md). Included by the top-level
# CMakeLists.txt after src/ (it needs the emadiag target and EMADIAG_DOCS_DIR).
#
# Layout (GNUInstallDirs; the package uses the prefix /usr):
#   bin/emadiag                                  the tool; it finds its data from its own location
#   share/emadiag/models/*.json                  the shipped network models
#   share/emadiag/can_dbc/ema.dbc                the EMA's CAN interface (its ICD: share/doc/emadiag/can-icd.md)
#   share/emadiag/actuators/                     actuator profiles (when the source tree has them)
#   share/doc/emadiag/                           README, docs/, copyright, changelog.gz
#   share/man/man1/emadiag.1.gz, emadiag-*.1.gz  manual pages, generated from the CLI's definitions
#   share/bash-completion/completions/emadiag    bash completion (generated likewise)
#   share/zsh/vendor-completions/_emadiag        zsh completion
#   libexec/emadiag/with_vcan.sh, test-run-demo.sh, ...  the vcan helper (user-mode Linux) and the demo test run
include(GNUInstallDirs)
# `cmake --install` and cpack install what is built, and build nothing themselves (without this they
# would build every test and benchmark first): scripts/package/build_deb.sh builds emadiag and its docs.
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)
# Directories 0755 whatever the umask (lintian: non-standard-dir-perm).
set(CMAKE_INSTALL_DEFAULT_DIRECTORY_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)

set(EMADIAG_PKG_DIR ${PROJECT_SOURCE_DIR}/scripts/package)
install(TARGETS emadiag RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/models/ DESTINATION ${CMAKE_INSTALL_DATADIR}/emadiag/models FILES_MATCHING PATTERN "*.json")
install(FILES ${PROJECT_SOURCE_DIR}/can_dbc/ema.dbc DESTINATION ${CMAKE_INSTALL_DATADIR}/emadiag/can_dbc)
install(FILES ${PROJECT_SOURCE_DIR}/can_dbc/ICD.md DESTINATION ${CMAKE_INSTALL_DOCDIR} RENAME can-icd.md)
if(EXISTS ${PROJECT_SOURCE_DIR}/actuators)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/actuators/ DESTINATION ${CMAKE_INSTALL_DATADIR}/emadiag/actuators)
endif()

file(GLOB EMADIAG_DOC_FILES ${PROJECT_SOURCE_DIR}/docs/*.md ${PROJECT_SOURCE_DIR}/docs/*.svg)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${EMADIAG_PKG_DIR}/copyright DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${PROJECT_SOURCE_DIR}/models/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR} RENAME models.md)
install(FILES ${EMADIAG_DOC_FILES} DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs)
# The changelog, compressed as Debian wants it (gzip -9n: no name, no time stamp, so reproducible).
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${EMADIAG_PKG_DIR}/changelog)
file(MAKE_DIRECTORY ${PROJECT_BINARY_DIR}/package)
execute_process(COMMAND gzip -9n -c ${EMADIAG_PKG_DIR}/changelog OUTPUT_FILE ${PROJECT_BINARY_DIR}/package/changelog.gz)
install(FILES ${PROJECT_BINARY_DIR}/package/changelog.gz DESTINATION ${CMAKE_INSTALL_DOCDIR})

install(DIRECTORY ${EMADIAG_DOCS_DIR}/man1/ DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 FILES_MATCHING PATTERN "*.1.gz")
install(FILES ${EMADIAG_DOCS_DIR}/completion/emadiag DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions)
install(FILES ${EMADIAG_DOCS_DIR}/completion/_emadiag DESTINATION ${CMAKE_INSTALL_DATADIR}/zsh/vendor-completions)

install(PROGRAMS ${PROJECT_SOURCE_DIR}/scripts/vcan/with_vcan.sh ${PROJECT_SOURCE_DIR}/scripts/vcan/with_vcan_vm.sh
                 ${PROJECT_SOURCE_DIR}/scripts/test-run-demo.sh
        DESTINATION ${CMAKE_INSTALL_LIBEXECDIR}/emadiag)
install(FILES ${PROJECT_SOURCE_DIR}/scripts/vcan/guest_priority.sh DESTINATION ${CMAKE_INSTALL_LIBEXECDIR}/emadiag)  # sourced, not run

# The Debian package: CPack's DEB generator (why not debhelper: docs/install.md).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME emadiag)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_PACKAGE_CONTACT "emadiag maintainers <emadiag-maintainers@emadiag.org>")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "emadiag maintainers <emadiag-maintainers@emadiag.org>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "ground-maintenance diagnostics for flight-control actuators")
# CPack writes the summary as the synopsis line; this is the extended description below it.
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "emadiag runs a test sequence on an electromechanical flight-control actuator
 over its CAN bus, reconstructs the residual torque and estimates the health
 of its transmission (dry friction and efficiencies), gives a verdict and
 stores the session in a tamper-evident maintenance record (SQLite, or a
 PostgreSQL fleet server). It reports trends and remaining useful life per
 aircraft position and actuator serial, ranks a fleet, and writes a static
 fleet web site.")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # emadiag_<version>_amd64.deb
# Depends: computed by dpkg-shlibdeps from the libraries the binary links (libc6, libstdc++6,
# libgcc-s1, libsqlite3-0, libhwy1, libpq5). libpq5 is among them: the one binary links it for
# `sync` and --db postgresql://; the PostgreSQL server and psql are only suggested.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# Recommends: bash-completion (loads the completion script), and what the vcan helper (libexec/emadiag/with_vcan.sh) needs on a kernel without vcan;
# a station with a real CAN interface does without (apt-get --no-install-recommends).
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "bash-completion, user-mode-linux, iproute2, kmod")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "postgresql-client, can-utils, chromium, qemu-system-x86, linux-image-amd64, busybox-static")
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR}/package)
include(CPack)
