#ifndef PPM_COUNTERS_H
#define PPM_COUNTERS_H
/* counters shared by the passes (ppm_engine/counters.py Counter) */
#define CNT_NAN 0
#define CNT_STORED 1
#define CNT_OUTSIDE 2
#define CNT_OVERFLOW 3
#define CNT_OCCUPIED 4
#define CNT_ACTIVE 5
#define CNT_SINK 6
#define CNT_CAUSTIC 7
#define CNT_DIFFUSE_FIRST 8
#define N_COUNTERS 9
#endif
