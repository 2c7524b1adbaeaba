# FindPyArrow: Apache Arrow C++ and Parquet C++ as shipped inside the `pyarrow` wheel, linked
# by path as the imported targets pyarrow::arrow and pyarrow::parquet (as FindMuJoCo links the
# mujoco wheel's libmujoco). Debian 12 has no Arrow packages; the wheel (pinned in
# requirements.txt) carries include/arrow, include/parquet, libarrow.so.<NNN> and
# libparquet.so.<NNN>, built with the C++11 string ABI (_GLIBCXX_USE_CXX11_ABI=1) like
# Debian's g++ default. Optional: without it, `export-lerobot` is not built (docs/lerobot.md).
#
# Where it looks: PYARROW_DIR (cache variable or environment: a pyarrow package directory),
# else the `pyarrow` package of MLSPACES_PYTHON.
#
# Sets PyArrow_FOUND, PyArrow_VERSION, PyArrow_INCLUDE_DIR, PyArrow_LIBRARY_DIR.

if(NOT PYARROW_DIR AND DEFINED ENV{PYARROW_DIR})
  set(PYARROW_DIR "$ENV{PYARROW_DIR}")
endif()
set(PYARROW_DIR "${PYARROW_DIR}" CACHE PATH "pyarrow Python package dir (include/, libarrow.so.*)")

set(_pyarrow_hint "${PYARROW_DIR}")
if(NOT _pyarrow_hint AND MLSPACES_PYTHON AND EXISTS "${MLSPACES_PYTHON}")
  execute_process(
    COMMAND "${MLSPACES_PYTHON}" -c
            "import importlib.util, os; s = importlib.util.find_spec('pyarrow'); print(os.path.dirname(s.origin) if s else '')"
    OUTPUT_VARIABLE _pyarrow_hint OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
endif()

unset(PyArrow_INCLUDE_DIR CACHE)
set(PyArrow_FOUND FALSE)
if(_pyarrow_hint AND EXISTS "${_pyarrow_hint}/include/arrow/api.h"
   AND EXISTS "${_pyarrow_hint}/include/parquet/arrow/writer.h")
  file(GLOB _pyarrow_arrow "${_pyarrow_hint}/libarrow.so.[0-9]*")
  file(GLOB _pyarrow_parquet "${_pyarrow_hint}/libparquet.so.[0-9]*")
  # The soname file (libarrow.so.2200), not the fully versioned one it may also ship.
  list(FILTER _pyarrow_arrow INCLUDE REGEX "libarrow\\.so\\.[0-9]+$")
  list(FILTER _pyarrow_parquet INCLUDE REGEX "libparquet\\.so\\.[0-9]+$")
  if(_pyarrow_arrow AND _pyarrow_parquet)
    list(GET _pyarrow_arrow 0 _pyarrow_arrow)
    list(GET _pyarrow_parquet 0 _pyarrow_parquet)
    file(STRINGS "${_pyarrow_hint}/include/arrow/util/config.h" _pyarrow_ver_line
         REGEX "^#define ARROW_VERSION_STRING ")
    string(REGEX REPLACE ".*\"([0-9.]+).*\".*" "\\1" PyArrow_VERSION "${_pyarrow_ver_line}")
    set(PyArrow_INCLUDE_DIR "${_pyarrow_hint}/include")
    set(PyArrow_LIBRARY_DIR "${_pyarrow_hint}")
    set(PyArrow_FOUND TRUE)
    if(NOT TARGET pyarrow::arrow)
      add_library(pyarrow::arrow SHARED IMPORTED GLOBAL)
      set_target_properties(pyarrow::arrow PROPERTIES
        IMPORTED_LOCATION "${_pyarrow_arrow}"
        INTERFACE_INCLUDE_DIRECTORIES "${PyArrow_INCLUDE_DIR}")
      add_library(pyarrow::parquet SHARED IMPORTED GLOBAL)
      set_target_properties(pyarrow::parquet PROPERTIES
        IMPORTED_LOCATION "${_pyarrow_parquet}"
        INTERFACE_INCLUDE_DIRECTORIES "${PyArrow_INCLUDE_DIR}"
        INTERFACE_LINK_LIBRARIES pyarrow::arrow)
    endif()
  endif()
endif()
if(PyArrow_FOUND)
  message(STATUS "Arrow C++ ${PyArrow_VERSION} from ${PyArrow_LIBRARY_DIR} (export-lerobot)")
else()
  message(STATUS "No pyarrow wheel with Arrow C++ for ${MLSPACES_PYTHON}: export-lerobot is not "
                 "built (pip install -r requirements.txt, or pass -DPYARROW_DIR=<pyarrow dir>)")
endif()
