# The environment of the ASan + UBSan test runs (scripts/test.sh, scripts/stress-tests.sh):
# source it. ROOT: the project root.
#
# intercept_tls_get_addr=0: GCC 12's sanitizer runtime tells a dynamic TLS block's bounds by a
# glibc 2.19 heuristic: a block that happens to start 16 bytes into a page is taken to follow a
# {size, start} header, and the 16 bytes before it (here ASan's own chunk header) become the
# bounds. LeakSanitizer's tracer then scans a range such as 0x4c15-0x1800005d17 and dies at
# exit ("Tracer caught signal 11 ... LeakSanitizer has encountered a fatal error"), for a
# process whose memory happens to fall that way: one resumed run of DatagenCliTest.KilledAt...
# hit it in every run of one build and in none of the build before (google/sanitizers#1322;
# LLVM 17 asks its allocator instead). docs/testing.md has the details. Without the interceptor the
# blocks are still scanned: they are heap chunks that the thread's DTV, in its static TLS,
# points to.
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:intercept_tls_get_addr=0
export UBSAN_OPTIONS=print_stacktrace=1
export LSAN_OPTIONS="suppressions=$ROOT/scripts/lsan-suppressions.txt"
