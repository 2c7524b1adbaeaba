# FindMuJoCo: the MuJoCo C library mlspaces links, by path, as the imported target
# mujoco::mujoco.
#
# Where it looks:
#   MUJOCO_DIR (cache variable or environment): a prefix holding include/mujoco/mujoco.h and
#     lib/libmujoco.so* (a release tarball, a source install), or a `mujoco` Python package
#     directory (site-packages/mujoco, which holds include/mujoco/ and libmujoco.so.<version>).
#   otherwise the `mujoco` package of MLSPACES_PYTHON (default: <repo>/.venv/bin/python, made
#     by scripts/install-deps.sh from requirements.txt, where the version is pinned).
#
# The wheel ships the library under its versioned name only (libmujoco.so.3.5.0, no
# symlink); we link that file by path and the targets that link it get its directory as
# RPATH, so nothing needs LD_LIBRARY_PATH. MuJoCo 2.x and untested major versions are refused
# at configure time (MLSPACES_MUJOCO_MAJOR is the major version this tree is written for).
#
# Errors are one line each (a leading space keeps CMake from wrapping them).
#
# Sets MuJoCo_FOUND, MuJoCo_VERSION, MuJoCo_INCLUDE_DIR, MuJoCo_LIBRARY, MuJoCo_LIBRARY_DIR.

set(MLSPACES_MUJOCO_MAJOR 3)

if(NOT MUJOCO_DIR AND DEFINED ENV{MUJOCO_DIR})
  set(MUJOCO_DIR "$ENV{MUJOCO_DIR}")
endif()
set(MUJOCO_DIR "${MUJOCO_DIR}" CACHE PATH
    "MuJoCo prefix (include/mujoco/, lib/libmujoco.so*) or mujoco Python package dir")

set(_mujoco_hint "")
if(MUJOCO_DIR)
  set(_mujoco_hint "${MUJOCO_DIR}")
  set(_mujoco_where "MUJOCO_DIR=${MUJOCO_DIR}")
else()
  if(NOT MLSPACES_PYTHON OR NOT EXISTS "${MLSPACES_PYTHON}")
    message(FATAL_ERROR " MuJoCo: no MUJOCO_DIR and no project venv python at "
                        "'${MLSPACES_PYTHON}': run scripts/install-deps.sh, or pass "
                        "-DMUJOCO_DIR=<prefix>")
  endif()
  execute_process(
    COMMAND "${MLSPACES_PYTHON}" -c
            "import importlib.util, os; s = importlib.util.find_spec('mujoco'); print(os.path.dirname(s.origin) if s else '')"
    OUTPUT_VARIABLE _mujoco_hint OUTPUT_STRIP_TRAILING_WHITESPACE
    RESULT_VARIABLE _mujoco_rc ERROR_QUIET)
  if(NOT _mujoco_rc EQUAL 0 OR NOT _mujoco_hint)
    message(FATAL_ERROR " MuJoCo: ${MLSPACES_PYTHON} has no 'mujoco' package: run "
                        "scripts/install-deps.sh (pip install -r requirements.txt), or pass "
                        "-DMUJOCO_DIR=<prefix>")
  endif()
  set(_mujoco_where "the mujoco package of ${MLSPACES_PYTHON} (${_mujoco_hint})")
endif()

# Re-resolve every configure: the venv or MUJOCO_DIR may have changed since the cache was made.
unset(MuJoCo_INCLUDE_DIR CACHE)
unset(MuJoCo_LIBRARY CACHE)
find_path(MuJoCo_INCLUDE_DIR mujoco/mujoco.h
          PATHS "${_mujoco_hint}" PATH_SUFFIXES include NO_DEFAULT_PATH)
# libmujoco.so.<version> (wheel), else libmujoco.so (tarball/install lib/ or lib64/).
file(GLOB _mujoco_libs "${_mujoco_hint}/libmujoco.so.*" "${_mujoco_hint}/lib/libmujoco.so.*"
     "${_mujoco_hint}/lib64/libmujoco.so.*")
list(SORT _mujoco_libs)
if(_mujoco_libs)
  list(GET _mujoco_libs -1 MuJoCo_LIBRARY)
  set(MuJoCo_LIBRARY "${MuJoCo_LIBRARY}" CACHE FILEPATH "MuJoCo shared library")
else()
  find_library(MuJoCo_LIBRARY mujoco PATHS "${_mujoco_hint}" PATH_SUFFIXES lib lib64
               NO_DEFAULT_PATH)
endif()
if(NOT MuJoCo_INCLUDE_DIR OR NOT MuJoCo_LIBRARY)
  message(FATAL_ERROR " MuJoCo: no include/mujoco/mujoco.h or libmujoco.so in ${_mujoco_where}")
endif()

# mjVERSION_HEADER is 100*major + 10*minor + patch (2.2.2 -> 222) through 3.x, then 3.5.0 ->
# 3005000 style in newer headers; read both forms.
file(STRINGS "${MuJoCo_INCLUDE_DIR}/mujoco/mujoco.h" _mujoco_ver_line
     REGEX "^#define mjVERSION_HEADER [0-9]+")
string(REGEX REPLACE "^#define mjVERSION_HEADER ([0-9]+).*" "\\1" _mujoco_ver "${_mujoco_ver_line}")
if(NOT _mujoco_ver)
  message(FATAL_ERROR " MuJoCo: cannot read mjVERSION_HEADER from ${MuJoCo_INCLUDE_DIR}/mujoco/mujoco.h")
endif()
if(_mujoco_ver GREATER_EQUAL 1000000)
  math(EXPR _mujoco_major "${_mujoco_ver} / 1000000")
  math(EXPR _mujoco_minor "(${_mujoco_ver} / 1000) % 1000")
  math(EXPR _mujoco_patch "${_mujoco_ver} % 1000")
else()
  math(EXPR _mujoco_major "${_mujoco_ver} / 100")
  math(EXPR _mujoco_minor "(${_mujoco_ver} / 10) % 10")
  math(EXPR _mujoco_patch "${_mujoco_ver} % 10")
endif()
set(MuJoCo_VERSION "${_mujoco_major}.${_mujoco_minor}.${_mujoco_patch}")
if(NOT _mujoco_major EQUAL MLSPACES_MUJOCO_MAJOR)
  message(FATAL_ERROR " MuJoCo ${MuJoCo_VERSION} found in ${_mujoco_where}: mlspaces needs "
                      "MuJoCo ${MLSPACES_MUJOCO_MAJOR}.x (pinned in requirements.txt)")
endif()

get_filename_component(MuJoCo_LIBRARY_DIR "${MuJoCo_LIBRARY}" DIRECTORY)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(MuJoCo REQUIRED_VARS MuJoCo_LIBRARY MuJoCo_INCLUDE_DIR
                                  VERSION_VAR MuJoCo_VERSION)
if(MuJoCo_FOUND AND NOT TARGET mujoco::mujoco)
  add_library(mujoco::mujoco SHARED IMPORTED)
  set_target_properties(mujoco::mujoco PROPERTIES
    IMPORTED_LOCATION "${MuJoCo_LIBRARY}"
    IMPORTED_NO_SONAME FALSE
    INTERFACE_INCLUDE_DIRECTORIES "${MuJoCo_INCLUDE_DIR}")
endif()
