# What makes the build faster without changing what it builds (docs/architecture.md, "The build
# and the tests"; measured on the 2-core machine):
# - LLVM's lld links skylit's programs about three times faster than GNU ld (test_live: 0.6 s
#   against 1.8 s); scripts/install-deps.sh installs it. Without it the default linker is used.
# - GCC collects its garbage less often: a translation unit compiles 4-5% faster (test_blend:
#   14.6 s against 15.2 s) for at most a gigabyte more memory per compiler.
include(CheckLinkerFlag)
check_linker_flag(CXX -fuse-ld=lld SKYLIT_HAVE_LLD)
if(SKYLIT_HAVE_LLD)
  add_link_options(-fuse-ld=lld)
endif()
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  add_compile_options(--param=ggc-min-expand=100 --param=ggc-min-heapsize=1048576)
endif()
