# Every dependency comes from a Debian 12 package. A missing one stops the
# configure step with the package to install (tools/install_deps.sh installs them all).

function(furn_missing what debian_package)
  message(FATAL_ERROR
    "Missing dependency ${what}: install the Debian package '${debian_package}' "
    "(apt-get install ${debian_package}), or run tools/install_deps.sh")
endfunction()

macro(furn_find_package name debian_package)
  find_package(${name} ${ARGN} QUIET)
  if(NOT ${name}_FOUND)
    furn_missing(${name} ${debian_package})
  endif()
endmacro()

furn_find_package(Eigen3 libeigen3-dev 3.3 NO_MODULE)
furn_find_package(PCL libpcl-dev 1.12 COMPONENTS common io search kdtree features filters
                  segmentation sample_consensus surface)
furn_find_package(assimp libassimp-dev 5)
furn_find_package(embree libembree-dev 3)
furn_find_package(OpenCV libopencv-dev 4 COMPONENTS core imgproc imgcodecs)
furn_find_package(Ceres libceres-dev 2)
furn_find_package(SQLite3 libsqlite3-dev)
furn_find_package(nlohmann_json nlohmann-json3-dev 3)
furn_find_package(CLI11 libcli11-dev)
furn_find_package(yaml-cpp libyaml-cpp-dev)
furn_find_package(Threads build-essential)
furn_find_package(ZLIB zlib1g-dev)
furn_find_package(PNG libpng-dev)
# The learned vote map (core/vote_net.cc): PyTorch's C++ library, CPU.
furn_find_package(Torch libtorch-dev)
# Data-parallel training (issue 70): torch's c10d process groups over Gloo;
# Debian's libtorch has them built in, its headers include Gloo's.
find_path(GLOO_INCLUDE_DIR gloo/context.h)
find_library(GLOO_LIBRARY gloo)
if(NOT GLOO_INCLUDE_DIR OR NOT GLOO_LIBRARY)
  furn_missing(Gloo libgloo-dev)
endif()

find_package(PkgConfig QUIET)
if(NOT PkgConfig_FOUND)
  furn_missing(pkg-config pkg-config)
endif()
pkg_check_modules(OSMESA IMPORTED_TARGET osmesa)
if(NOT OSMESA_FOUND)
  furn_missing(OSMesa libosmesa6-dev)
endif()
# libzip's CMake config on Debian 12 names tool binaries the -dev package does
# not ship, so it is found through pkg-config.
pkg_check_modules(LIBZIP IMPORTED_TARGET libzip)
if(NOT LIBZIP_FOUND)
  furn_missing(libzip libzip-dev)
endif()
pkg_check_modules(XXHASH IMPORTED_TARGET libxxhash)
if(NOT XXHASH_FOUND)
  furn_missing(xxhash libxxhash-dev)
endif()
# Report figures are drawn in-process by PLplot's cairo driver (no plotting
# program is fed a script); the driver is a runtime plug-in of its own package.
pkg_check_modules(PLPLOT IMPORTED_TARGET plplot)
if(NOT PLPLOT_FOUND)
  furn_missing(PLplot libplplot-dev)
endif()
pkg_check_modules(LIBDEFLATE IMPORTED_TARGET libdeflate)
if(NOT LIBDEFLATE_FOUND)
  furn_missing(libdeflate libdeflate-dev)
endif()
# MCAP bags' compressed chunks (ROS 2 Iron and later record MCAP by default).
pkg_check_modules(ZSTD IMPORTED_TARGET libzstd)
if(NOT ZSTD_FOUND)
  furn_missing(zstd libzstd-dev)
endif()
pkg_check_modules(LZ4 IMPORTED_TARGET liblz4)
if(NOT LZ4_FOUND)
  furn_missing(lz4 liblz4-dev)
endif()

if(FURN_BUILD_PYTHON)
  furn_find_package(Python3 python3-dev COMPONENTS Interpreter Development.Module)
  set(PYBIND11_FINDPYTHON ON)
  furn_find_package(pybind11 pybind11-dev 2.6 CONFIG)
endif()
if(FURN_BUILD_TESTS)
  furn_find_package(GTest libgtest-dev)
endif()
if(FURN_BUILD_BENCHMARKS)
  furn_find_package(benchmark libbenchmark-dev)
endif()

# ROS 1 bags (Debian's ROS Noetic packages). Libraries and headers are
# looked up directly: rosbag_storage's CMake config pulls in pluginlib and
# ament, which run a Python of the PATH at configure time, and the message
# packages' configs need catkin. The messages are headers only.
if(FURN_WITH_ROS)
  foreach(ros_library IN ITEMS rosbag_storage roscpp_serialization rostime cpp_common
                               console_bridge roslz4)
    find_library(FURN_ROS_LIBRARY_${ros_library} ${ros_library})
    if(NOT FURN_ROS_LIBRARY_${ros_library})
      furn_missing(${ros_library} librosbag-dev)
    endif()
    list(APPEND FURN_ROS_LIBRARIES ${FURN_ROS_LIBRARY_${ros_library}})
  endforeach()
  find_package(Boost COMPONENTS filesystem QUIET)
  if(NOT Boost_FOUND)
    furn_missing(boost_filesystem libboost-filesystem-dev)
  endif()
  list(APPEND FURN_ROS_LIBRARIES Boost::filesystem)
  foreach(ros_header IN ITEMS rosbag/bag.h sensor_msgs/PointCloud2.h sensor_msgs/Image.h
                              visualization_msgs/MarkerArray.h tf2_msgs/TFMessage.h
                              geometry_msgs/TransformStamped.h std_msgs/Header.h ros/time.h)
    string(REGEX REPLACE "/.*" "" ros_package "${ros_header}")
    string(REPLACE "_" "-" debian_name "${ros_package}")
    find_path(FURN_ROS_HEADER_${ros_package} ${ros_header})
    if(NOT FURN_ROS_HEADER_${ros_package})
      furn_missing(${ros_package} lib${debian_name}-dev)
    endif()
    list(APPEND FURN_ROS_INCLUDE_DIRS ${FURN_ROS_HEADER_${ros_package}})
  endforeach()
  # rosbag/bag.h includes pluginlib, whose headers live one folder down.
  foreach(nested IN ITEMS pluginlib class_loader ament_index_cpp rcpputils rcutils)
    find_path(FURN_ROS_NESTED_${nested} ${nested} PATH_SUFFIXES ${nested} NO_DEFAULT_PATH
              PATHS /usr/include)
    if(NOT FURN_ROS_NESTED_${nested})
      furn_missing(${nested} librosbag-dev)
    endif()
    list(APPEND FURN_ROS_INCLUDE_DIRS ${FURN_ROS_NESTED_${nested}})
  endforeach()
  list(REMOVE_DUPLICATES FURN_ROS_INCLUDE_DIRS)
endif()

# The 3-D scene view (reports/scene_view.cc) copies three.js from Debian's
# libjs-three into report folders; its release is recorded beside it.
find_path(FURN_THREE_JS_DIR three.min.js PATHS /usr/share/javascript/three NO_DEFAULT_PATH)
if(NOT FURN_THREE_JS_DIR OR NOT EXISTS "${FURN_THREE_JS_DIR}/examples/js/controls/OrbitControls.js")
  furn_missing(three.js libjs-three)
endif()
file(READ "${FURN_THREE_JS_DIR}/three.min.js" furn_three_head LIMIT 4096)
string(REGEX MATCH "REVISION=\"([0-9a-z]+)\"" furn_three_revision "${furn_three_head}")
if(NOT CMAKE_MATCH_1)
  message(FATAL_ERROR "${FURN_THREE_JS_DIR}/three.min.js: no REVISION in its first 4 kB")
endif()
set(FURN_THREE_JS_REVISION "${CMAKE_MATCH_1}")
