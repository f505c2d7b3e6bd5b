/* An experiment for bench/bench_libcosim.py, not used by the project: preloaded, it makes
 * get_nprocs() return 1, so std::thread::hardware_concurrency() is 1 and libcosim 0.11's
 * fixed-step algorithm creates its thread pool with no worker (hardware threads - 1): every
 * doStep runs inline in the calling thread.  libcosimc has no other way to set the pool's size.
 *   gcc -shared -fPIC -O2 -o /tmp/libnprocs1.so bench/nprocs1_shim.c
 *   LD_PRELOAD=/tmp/libnprocs1.so python bench/bench_libcosim.py */
int get_nprocs(void);
int get_nprocs_conf(void);

int get_nprocs(void) { return 1; }
int get_nprocs_conf(void) { return 1; }
