/* What the test harness needs from the operating system: load a shared library, find a
 * symbol, a monotonic clock. POSIX (dlopen, clock_gettime) or Windows (LoadLibrary,
 * QueryPerformanceCounter; built with mingw-w64 and run natively or under wine).
 * Include before any other header. */
#ifndef HARNESS_OS_H
#define HARNESS_OS_H

#ifdef _WIN32
#include <windows.h>

static void *open_library(const char *path) { return (void *)LoadLibraryA(path); }
static void *find_symbol(void *lib, const char *name) {
    return (void *)GetProcAddress((HMODULE)lib, name);
}
static void close_library(void *lib) { FreeLibrary((HMODULE)lib); }
static const char *library_error(void) { return "LoadLibrary failed"; }
static double now_us(void) {
    LARGE_INTEGER count, frequency;
    QueryPerformanceCounter(&count);
    QueryPerformanceFrequency(&frequency);
    return (double)count.QuadPart * 1e6 / (double)frequency.QuadPart;
}
#else
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <time.h>

static void *open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *find_symbol(void *lib, const char *name) { return dlsym(lib, name); }
static void close_library(void *lib) { dlclose(lib); }
static const char *library_error(void) { return dlerror(); }
static double now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e6 + ts.tv_nsec * 1e-3;
}
#endif

#endif /* HARNESS_OS_H */
