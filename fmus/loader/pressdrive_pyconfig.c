/* pressdrive host loader, part 2 (standalone FMUs only): start the interpreter the FMU carries.
 *
 * Compiled against the headers of the Python that the FMU carries (fmus/standalone.py: its PyConfig's layout is
 * that version's) and linked into that FMU's loader beside pressdrive_loader.c.  The interpreter starts isolated
 * (PyConfig_InitIsolatedConfig: no PYTHON* variable, no user site folder and no current folder of the machine
 * reaches it) with its home the FMU's own folder (binaries/<platform>/python), no signal handlers (the host's
 * stay) and its site module (the bundled site-packages with numpy).  Every function of libpython is looked up
 * with dlsym in the library the loader opened: this file, like the rest of the loader, links no libpython.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <dlfcn.h>
#include <stdio.h>

int pressdrive_start_isolated(void *libpython, const char *home, char *err, size_t n) {
    __typeof__(&PyConfig_InitIsolatedConfig) init_config = dlsym(libpython, "PyConfig_InitIsolatedConfig");
    __typeof__(&PyConfig_SetBytesString) set_string = dlsym(libpython, "PyConfig_SetBytesString");
    __typeof__(&Py_InitializeFromConfig) initialize = dlsym(libpython, "Py_InitializeFromConfig");
    __typeof__(&PyConfig_Clear) clear = dlsym(libpython, "PyConfig_Clear");
    __typeof__(&PyStatus_Exception) failed = dlsym(libpython, "PyStatus_Exception");
    if (!init_config || !set_string || !initialize || !clear || !failed) {
        snprintf(err, n, "this FMU's own Python lacks the PyConfig API (Python 3.8 or newer has it)");
        return -1;
    }
    PyConfig config;
    init_config(&config);
    config.install_signal_handlers = 0;
    config.site_import = 1;
    PyStatus status = set_string(&config, &config.home, home);
    if (!failed(status)) status = set_string(&config, &config.program_name, "python3");
    if (!failed(status)) status = initialize(&config);
    clear(&config);
    if (failed(status)) {
        snprintf(err, n, "this FMU's own Python (home '%s') does not start: %s%s%s", home,
                 status.func ? status.func : "", status.func ? ": " : "", status.err_msg ? status.err_msg : "");
        return -1;
    }
    return 0;
}
