# The OpenVDB fixtures of test_vdb (tests/support/vdb_fixtures.cpp): C++ test code that writes
# .vdb files and reads them back independently. Compiled into test_vdb only, so that libvis
# carries no test code. Included by tests/CMakeLists.txt.
if(VIS_WITH_OPENVDB AND TARGET test_vdb)
  enable_language(CXX)
  set(CMAKE_CXX_STANDARD 17)
  list(APPEND CMAKE_MODULE_PATH /usr/lib/x86_64-linux-gnu/cmake/OpenVDB /usr/lib/cmake/OpenVDB)
  find_package(OpenVDB REQUIRED)
  target_sources(test_vdb PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/support/vdb_fixtures.cpp)
  target_link_libraries(test_vdb PRIVATE OpenVDB::openvdb)
endif()
