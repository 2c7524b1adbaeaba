// The program the tests' precompiled header is built with (tests/CMakeLists.txt).
int main() { return 0; }
