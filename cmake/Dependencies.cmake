# Every dependency comes from a Debian 12 package (scripts/install-deps.sh installs them).
# Nothing is downloaded at build time.
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs calib3d photo videoio)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(spdlog REQUIRED)
find_package(CLI11 REQUIRED)
find_package(OpenEXR 3 REQUIRED)
find_package(Imath REQUIRED)
find_package(TinyGLTF REQUIRED)
# KHR_draco_mesh_compression, decoded by skylit (src/scene/src/draco_primitive.cpp).
find_package(draco REQUIRED)
find_package(tinyobjloader REQUIRED)
find_package(Ceres 2 REQUIRED)
find_package(embree 3 REQUIRED)
find_package(OpenSSL REQUIRED COMPONENTS Crypto)
find_package(glfw3 3.3 REQUIRED)
pkg_check_modules(EGL REQUIRED IMPORTED_TARGET egl)
pkg_check_modules(GLESV2 REQUIRED IMPORTED_TARGET glesv2)
pkg_check_modules(EXIF REQUIRED IMPORTED_TARGET libexif)
# Every file that includes <httplib.h> must link this: its definitions (OpenSSL, zlib, Brotli
# support) change httplib's classes, and two layouts in one program crash it.
pkg_check_modules(HTTPLIB REQUIRED IMPORTED_TARGET cpp-httplib)
# The MQTT client of the site link (src/sky_link); the tests start Debian's mosquitto broker.
pkg_check_modules(MOSQUITTO REQUIRED IMPORTED_TARGET libmosquitto)
# Used by later modules (tracking, IMU, cameras); found now so the build knows them.
pkg_check_modules(APRILTAG REQUIRED IMPORTED_TARGET apriltag)
pkg_check_modules(HIDAPI REQUIRED IMPORTED_TARGET hidapi-hidraw)
pkg_check_modules(LIBCAMERA REQUIRED IMPORTED_TARGET libcamera)
find_package(GTest REQUIRED)
find_package(benchmark REQUIRED)
find_program(GLSLANG_VALIDATOR glslangValidator REQUIRED)

# yaml-cpp 0.7 on Debian exports the plain target name.
if(TARGET yaml-cpp AND NOT TARGET yaml-cpp::yaml-cpp)
  add_library(yaml-cpp::yaml-cpp ALIAS yaml-cpp)
endif()
if(TARGET tinyobjloader::tinyobjloader)
  set(SKYLIT_TINYOBJ tinyobjloader::tinyobjloader)
else()
  set(SKYLIT_TINYOBJ tinyobjloader)
endif()
