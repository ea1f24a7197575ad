// The stub that each shared precompiled header (cmake/SharedPch.cmake) is compiled with.
