// The empty source each shared precompiled header (cmake/SharedPch.cmake) is compiled with.
