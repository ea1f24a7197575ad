# cmake -DLIBRARY=lib.glsl -DOUT=lib.glsl.frag -P WrapShaderLibrary.cmake: a shader library
# (shaders/*.glsl, no #version) as a fragment shader that glslangValidator can check.
file(READ ${LIBRARY} text)
file(WRITE ${OUT} "#version 310 es\nprecision highp float;\nprecision highp int;\n#line 1\n${text}")
