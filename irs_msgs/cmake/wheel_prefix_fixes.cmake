# Fixes for building ROS 2 interface packages against the ros-jazzy-* wheels.
#
# Loaded with -DCMAKE_PROJECT_INCLUDE=<this file> (see the workspace Makefile), so it runs right
# after project() of every ament_cmake package in the workspace.
#
# Why: the wheels were built in a manylinux container whose Python lived at
# /opt/python/cp311-cp311. The CMake exports of the installed message packages (for example
# std_msgs::std_msgs__rosidl_generator_py) still name that include directory in their
# INTERFACE_INCLUDE_DIRECTORIES. CMake refuses to generate build files for a target that links an
# imported target with a non-existent include path ("CMake Generate step failed"), so colcon stops.
# The same exports also name that container's NumPy headers
# (/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include).
# We cannot change the installed wheels, so at the end of configuring we replace those paths in
# every imported target with the Python and NumPy include directories of the Python we build for.

find_package(Python3 REQUIRED COMPONENTS Interpreter Development NumPy)

function(irs_fix_wheel_include_dirs)
  get_property(_targets DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(_target IN LISTS _targets)
    get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT _dirs OR NOT _dirs MATCHES "/opt/python/")
      continue()
    endif()
    list(TRANSFORM _dirs REPLACE "^/opt/python/[^/]+/lib/python3[.0-9]+/site-packages/numpy/.*$"
      "${Python3_NumPy_INCLUDE_DIRS}")
    list(TRANSFORM _dirs REPLACE "^/opt/python/[^/]+/include/python3[.0-9]+$" "${Python3_INCLUDE_DIRS}")
    set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_dirs}")
  endforeach()
endfunction()

# Imported targets appear only when the package calls find_package() later in its
# CMakeLists.txt, so defer the fix to the end of the top-level directory.
cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL irs_fix_wheel_include_dirs)
