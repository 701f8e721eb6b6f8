# visibility.cmake — compiles the visibility sources into the native static library and links
# Embree 3 (oriented-disc points for visibility="exact").
#
# Usage, in core/CMakeLists.txt after add_library(illumap_native ...):
#     include(cmake/visibility.cmake)
#     illumap_add_visibility(illumap_native)
#
# Which Embree: ILLUMAP_EMBREE_DIR names an Embree 3 CMake config folder. The portable wheels
# (scripts/build_wheels.py) point it at the static Embree that scripts/build_embree.py builds
# without TBB; without it, find_package finds the system's (Debian: libembree3.so.3, which pulls
# libtbb.so.12), as a plain `pip install ./core` does for development.
include_guard(GLOBAL)

set(ILLUMAP_VISIBILITY_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/../src/visibility/visibility.cpp
  ${CMAKE_CURRENT_LIST_DIR}/../src/visibility/visibility_factory.cpp
  ${CMAKE_CURRENT_LIST_DIR}/../src/visibility/raycast.cpp
  ${CMAKE_CURRENT_LIST_DIR}/../src/visibility/mesh_scene.cpp
  ${CMAKE_CURRENT_LIST_DIR}/../src/gather/gather.cpp
  ${CMAKE_CURRENT_LIST_DIR}/../src/gather/surfel_field.cpp
  ${CMAKE_CURRENT_LIST_DIR}/../src/visibility/seed_visibility.cpp)

if(DEFINED ILLUMAP_EMBREE_DIR)
  set(embree_DIR "${ILLUMAP_EMBREE_DIR}")
endif()
find_package(embree 3 REQUIRED)

function(illumap_add_visibility target)
  target_sources(${target} PRIVATE ${ILLUMAP_VISIBILITY_SOURCES})
  # Embree's exported target is called `embree` (headers <embree3/rtcore.h>).
  target_link_libraries(${target} PUBLIC embree)
  target_compile_definitions(${target} PUBLIC ILLUMAP_HAVE_VISIBILITY=1)
endfunction()
