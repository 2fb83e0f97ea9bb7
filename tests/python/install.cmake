# Installs the build tree into WORK_DIR/install and imports ccfr from there alone (not the build
# tree): the package, its extension and stub land in PREFIX/PYDIR/ccfr.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BINARY_DIR} --prefix ${WORK_DIR}/install
                RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}): ${err}")
endif()
foreach(f __init__.py __init__.pyi py.typed)
  if(NOT EXISTS ${WORK_DIR}/install/${PYDIR}/ccfr/${f})
    message(FATAL_ERROR "not installed: ${PYDIR}/ccfr/${f}")
  endif()
endforeach()
set(script [=[
import os, sys
prefix = sys.argv[1]
import ccfr
assert os.path.realpath(ccfr.__file__).startswith(os.path.realpath(prefix)), ccfr.__file__
sim = ccfr.Simulation(ccfr.load_scene(sys.argv[2], overrides={"time.frames": 1}), threads=1)
sim.step()
print("installed ccfr ok", ccfr.__file__, sim.positions.shape)
]=])
execute_process(COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${WORK_DIR}/install/${PYDIR} PYTHONDONTWRITEBYTECODE=1
                        ${PYTHON} -c "${script}" ${WORK_DIR}/install ${SCENE}
                WORKING_DIRECTORY ${WORK_DIR} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "installed ccfr ok")
  message(FATAL_ERROR "import after install failed (${rc}):\n${out}\n${err}")
endif()
message(STATUS "${out}")
