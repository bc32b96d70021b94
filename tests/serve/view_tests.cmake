# `diskchungs view` end to end: view_cli (flags, taken port, Ctrl-C, folder unchanged; Python) and
# view_browser (the page in headless Chromium; skipped, exit 77, without Chromium, and not registered
# without node and npm, since the page is not built then).
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  add_test(NAME view_cli COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/view_cli_test.py
                                 --cli $<TARGET_FILE:diskchungs>)
  set_tests_properties(view_cli PROPERTIES TIMEOUT 120 ENVIRONMENT "OMP_NUM_THREADS=2")
endif()
if(CHUNGS_WITH_WEB)
  find_program(CHROMIUM_EXECUTABLE NAMES chromium chromium-browser)
  if(NOT CHROMIUM_EXECUTABLE)
    set(CHROMIUM_EXECUTABLE /usr/bin/chromium)  # the test says it is missing and skips
  endif()
  add_test(NAME view_browser
           COMMAND ${NODE_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/view_browser_test.mjs
                   --cli $<TARGET_FILE:diskchungs> --modules ${CMAKE_BINARY_DIR}/web/node_modules
                   --chromium ${CHROMIUM_EXECUTABLE})
  set_tests_properties(view_browser PROPERTIES TIMEOUT 300 SKIP_RETURN_CODE 77 LABELS browser
                       ENVIRONMENT "OMP_NUM_THREADS=2")
else()
  message(STATUS "Browser test view_browser: not registered (no viewer page: CHUNGS_WEB=OFF or no node/npm)")
endif()
