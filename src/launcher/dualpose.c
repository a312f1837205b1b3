/* The `dualpose` command: a launcher that blocks SIGINT, then executes the environment's Python on the command line
 * (`_dualpose_cli.main`).  The blocked signal mask survives execve, so a Ctrl-C during the interpreter's own start-up
 * (site, .pth files, the entry module's import) stays pending; `_dualpose_cli.main` installs its handler, unblocks
 * SIGINT, and a pending Ctrl-C then exits 130 quietly (docs/refusals.md, "Ctrl-C during start-up").  An inherited
 * SIG_IGN (a background job) or an already blocked SIGINT is left as it is.  Built at install by CMakeLists.txt.
 *
 * The interpreter: PYTHON_NAME (python3.X, the version the package was built for) next to this executable (a virtual
 * environment's or conda environment's bin/), else the interpreter that built the package (DUALPOSE_BUILD_PYTHON), else
 * python3 or python next to this executable. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#ifdef __APPLE__
#include <mach-o/dyld.h>
#include <stdint.h>
#endif

#ifndef DUALPOSE_BUILD_PYTHON
#error "DUALPOSE_BUILD_PYTHON (the interpreter's path) is set by CMakeLists.txt"
#endif
#ifndef PYTHON_NAME
#error "PYTHON_NAME (python3.X) is set by CMakeLists.txt"
#endif

/* sys.path[0] is '' (the working directory) under -c: dropped, as the installer's wrapper script has its own folder
 * there, so that a file in the working directory never shadows a module; sys.argv[0] becomes the command's name */
#define PROLOGUE                                                                                                       \
    "import sys\n"                                                                                                     \
    "if sys.path and sys.path[0] == '':\n"                                                                             \
    "    del sys.path[0]\n"                                                                                            \
    "sys.argv[:2] = sys.argv[1:2]\n"                                                                                   \
    "from _dualpose_cli import main\n"
static const char CODE_UNBLOCK[] = PROLOGUE "sys.exit(main(unblock_sigint=True))\n";
static const char CODE_AS_IS[] = PROLOGUE "sys.exit(main())\n";

/* this executable's path with symbolic links resolved, into out[PATH_MAX]; 0 on success */
static int own_path(const char *argv0, char *out) {
#if defined(__linux__)
    ssize_t n = readlink("/proc/self/exe", out, PATH_MAX - 1);
    if (n > 0) {
        out[n] = '\0';
        return 0;
    }
#elif defined(__APPLE__)
    char buf[PATH_MAX];
    uint32_t size = sizeof buf;
    if (_NSGetExecutablePath(buf, &size) == 0 && realpath(buf, out) != NULL)
        return 0;
#endif
    if (strchr(argv0, '/') != NULL)
        return realpath(argv0, out) != NULL ? 0 : -1;
    const char *path = getenv("PATH");
    while (path != NULL && *path != '\0') {
        const char *end = strchr(path, ':');
        size_t len = end != NULL ? (size_t)(end - path) : strlen(path);
        char candidate[PATH_MAX];
        if (len > 0 && snprintf(candidate, sizeof candidate, "%.*s/%s", (int)len, path, argv0) < (int)sizeof candidate
            && access(candidate, X_OK) == 0 && realpath(candidate, out) != NULL)
            return 0;
        path = end != NULL ? end + 1 : NULL;
    }
    return -1;
}

/* dir/name into out[PATH_MAX] when it is executable; 0 on success */
static int executable_in(const char *dir, const char *name, char *out) {
    int n = snprintf(out, PATH_MAX, "%s/%s", dir, name);
    return n > 0 && n < PATH_MAX && access(out, X_OK) == 0 ? 0 : -1;
}

int main(int argc, char **argv) {
    const char *argv0 = argc > 0 && argv[0] != NULL ? argv[0] : "dualpose";

    int unblock = 0;
    struct sigaction current;
    if (sigaction(SIGINT, NULL, &current) == 0 && current.sa_handler != SIG_IGN) {
        sigset_t block, previous;
        sigemptyset(&block);
        sigaddset(&block, SIGINT);
        if (sigprocmask(SIG_BLOCK, &block, &previous) == 0 && !sigismember(&previous, SIGINT))
            unblock = 1;
    }

    static char self[PATH_MAX], python[PATH_MAX];
    char dir[PATH_MAX] = "";
    if (own_path(argv0, self) == 0) {
        char *slash = strrchr(self, '/');
        if (slash != NULL) {
            size_t len = (size_t)(slash - self);
            memcpy(dir, self, len);
            dir[len > 0 ? len : 1] = '\0';
            if (len == 0)
                dir[0] = '/';
        }
    }
    int found = (dir[0] != '\0' && executable_in(dir, PYTHON_NAME, python) == 0);
    if (!found && access(DUALPOSE_BUILD_PYTHON, X_OK) == 0 && strlen(DUALPOSE_BUILD_PYTHON) < PATH_MAX) {
        strcpy(python, DUALPOSE_BUILD_PYTHON);
        found = 1;
    }
    found = found || (dir[0] != '\0' && (executable_in(dir, "python3", python) == 0
                                         || executable_in(dir, "python", python) == 0));
    if (!found) {
        fprintf(stderr, "dualpose: error: no Python interpreter found for this installation (looked for %s and "
                        "python3 in %s, and for %s); run `python -m dualpose.cli.main` instead\n",
                PYTHON_NAME, dir[0] != '\0' ? dir : "the launcher's folder", DUALPOSE_BUILD_PYTHON);
        return 1;
    }

    /* python -c CODE NAME ARGS...: argv[0] stays the interpreter's path (CPython finds its environment from it) */
    char **args = calloc((size_t)argc + 4, sizeof *args);
    if (args == NULL) {
        fprintf(stderr, "dualpose: error: out of memory\n");
        return 1;
    }
    args[0] = python;
    args[1] = "-c";
    args[2] = (char *)(unblock ? CODE_UNBLOCK : CODE_AS_IS);
    args[3] = strchr(argv0, '/') != NULL || self[0] == '\0' ? (char *)argv0 : self;
    for (int i = 1; i < argc; ++i)
        args[3 + i] = argv[i];
    args[argc + 3] = NULL;
    execv(python, args);
    fprintf(stderr, "dualpose: error: cannot run the Python interpreter %s: %s\n", python, strerror(errno));
    return 1;
}
