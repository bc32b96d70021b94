# The viewer page (web/): `npm ci` from the committed lockfile and an esbuild bundle into
# ${CMAKE_BINARY_DIR}/web/dist, the folder `diskchungs view` serves when no installed copy or --web is
# given (its path is compiled into chungs_serve). node_modules lives in the build folder too, so the
# source tree stays clean and build folders do not share one.
# CHUNGS_WEB: AUTO builds it when node and npm are found, ON requires them, OFF skips it.
set(CHUNGS_WEB AUTO CACHE STRING "Build the viewer page (needs node and npm): AUTO, ON or OFF")
set_property(CACHE CHUNGS_WEB PROPERTY STRINGS AUTO ON OFF)
set(CHUNGS_WEB_DIST ${CMAKE_BINARY_DIR}/web/dist)
set(CHUNGS_WITH_WEB OFF)
if(NOT CHUNGS_WEB STREQUAL "OFF")
  find_program(NODE_EXECUTABLE node)
  find_program(NPM_EXECUTABLE npm)
  if(NODE_EXECUTABLE AND NPM_EXECUTABLE)
    set(CHUNGS_WITH_WEB ON)
  elseif(CHUNGS_WEB STREQUAL "ON")
    message(FATAL_ERROR "CHUNGS_WEB=ON but node or npm is missing (apt-get install nodejs npm)")
  else()
    message(STATUS "Viewer page: skipped (node or npm not found; `diskchungs view` serves the API only)")
  endif()
endif()

if(CHUNGS_WITH_WEB)
  set(web_src ${PROJECT_SOURCE_DIR}/web)
  set(web_bin ${CMAKE_BINARY_DIR}/web)
  add_custom_command(
    OUTPUT ${web_bin}/npm-ci.stamp
    COMMAND ${CMAKE_COMMAND} -E make_directory ${web_bin}
    COMMAND ${CMAKE_COMMAND} -E copy ${web_src}/package.json ${web_src}/package-lock.json ${web_bin}/
    COMMAND ${NPM_EXECUTABLE} ci --no-audit --no-fund --loglevel=error
    COMMAND ${CMAKE_COMMAND} -E touch ${web_bin}/npm-ci.stamp
    WORKING_DIRECTORY ${web_bin}
    DEPENDS ${web_src}/package.json ${web_src}/package-lock.json
    COMMENT "npm ci (viewer page packages)"
    VERBATIM)
  file(GLOB web_inputs CONFIGURE_DEPENDS ${web_src}/src/*.ts ${web_src}/static/*)
  add_custom_command(
    OUTPUT ${CHUNGS_WEB_DIST}/index.html
    COMMAND ${NODE_EXECUTABLE} ${web_src}/build.mjs --modules ${web_bin}/node_modules --out ${CHUNGS_WEB_DIST}
    DEPENDS ${web_bin}/npm-ci.stamp ${web_src}/build.mjs ${web_inputs}
    COMMENT "Bundling the viewer page into ${CHUNGS_WEB_DIST}"
    VERBATIM)
  add_custom_target(web ALL DEPENDS ${CHUNGS_WEB_DIST}/index.html)
  install(DIRECTORY ${CHUNGS_WEB_DIST}/ DESTINATION share/diskchungs/web)
  message(STATUS "Viewer page: built into ${CHUNGS_WEB_DIST}")
endif()
