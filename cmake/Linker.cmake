# LLVM's lld links skylit's programs about three times faster than GNU ld (test_live: 0.6 s
# against 1.8 s on the 2-core machine); scripts/install-deps.sh installs it. Without it the
# compiler's default linker is used.
include(CheckLinkerFlag)
check_linker_flag(CXX -fuse-ld=lld SKYLIT_HAVE_LLD)
if(SKYLIT_HAVE_LLD)
  add_link_options(-fuse-ld=lld)
endif()
