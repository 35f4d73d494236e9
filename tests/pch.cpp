// Owns the precompiled header that the test executables reuse (see CMakeLists.txt).
