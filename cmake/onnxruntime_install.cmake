# `cmake -DNPM=... -DSRC=... -DDIR=... -DREQUIRED=ON|OFF -P onnxruntime_install.cmake`: installs the npm
# package that carries ONNX Runtime's library (cmake/onnxruntime.cmake says why) from the committed
# lockfile. --ignore-scripts: the package's install script would download GPU providers from outside
# the registry; the CPU library is in the package itself.
file(MAKE_DIRECTORY ${DIR})
file(COPY ${SRC}/package.json ${SRC}/package-lock.json DESTINATION ${DIR})
execute_process(COMMAND ${NPM} ci --ignore-scripts --no-audit --no-fund --loglevel=error
                WORKING_DIRECTORY ${DIR} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  if(REQUIRED)
    message(FATAL_ERROR "npm ci of ONNX Runtime (onnxruntime-node) failed in ${DIR}")
  endif()
  # Optional: the build goes on; --mono-depth-model then says what to install, its tests skip.
  message(WARNING "npm ci of ONNX Runtime (onnxruntime-node) failed in ${DIR}: --mono-depth-model will need "
                  "CHUNGS_ONNXRUNTIME or a system libonnxruntime.so.1 (delete ${DIR}/npm-ci.stamp to retry)")
endif()
file(TOUCH ${DIR}/npm-ci.stamp)
