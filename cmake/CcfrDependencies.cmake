# Every dependency is a Debian package; scripts/install-deps installs them.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(spdlog REQUIRED)
find_package(TBB REQUIRED)
find_package(fcl REQUIRED)            # imported target: plain `fcl`
find_package(CGAL REQUIRED)           # CGAL::CGAL (adds -frounding-math: geometry_exact only)
find_package(yaml-cpp REQUIRED)       # 0.7: plain `yaml-cpp`, no namespace
find_package(CLI11 CONFIG REQUIRED)
find_package(nlohmann_json 3 REQUIRED)  # run.json: nlohmann_json::nlohmann_json
find_package(ZLIB REQUIRED)           # compressed VTU frames (io/formats/src/formats.cpp): ZLIB::ZLIB
if(CCFR_BUILD_TESTS)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()
if(CCFR_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()
