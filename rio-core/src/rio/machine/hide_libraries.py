"""Run a child process as on a machine where some shared libraries are not installed, without
uninstalling anything: to prove that tests skip (and commands explain) what a bare machine lacks.

The child's dynamic loader is given an audit library (`LD_AUDIT`, glibc's rtld-audit interface) whose
`la_objsearch` answers every place it would find a hidden library (LD_LIBRARY_PATH, RUNPATH, the ld.so
cache, the default directories) with a path that does not exist. The search then ends as it does where
the file is absent: a binary wheel's extension that needs the library fails to import with the loader's
own error ("libusb-1.0.so.0: cannot open shared object file: No such file or directory"), and a ctypes
load of it fails the same way. It holds in the child's children too (the variables are inherited).
Loads by name are hidden (a soname, as dependencies and most ctypes loads are, and its development
link: libEGL.so.1 and libEGL.so), not a load by absolute path.

The audit library is compiled from the C below on first use, which needs a C compiler (`C_COMPILER`).
"""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterable, Mapping
from pathlib import Path

from rio.machine.system_needs import SystemNeed

#: What compiling the audit library needs.
C_COMPILER = SystemNeed("gcc", program="cc", purpose="hiding a shared library from a test's subprocess")

#: The variable the audit library reads: the hidden sonames, separated by ':'.
HIDDEN_VAR = "RIO_HIDDEN_LIBRARIES"

_SOURCE = r"""
#define _GNU_SOURCE
#include <link.h>
#include <stdlib.h>
#include <string.h>

unsigned int la_version(unsigned int version) { return version < LAV_CURRENT ? version : LAV_CURRENT; }

/* Whether the file name of `path` is a hidden soname ("libEGL.so.1") or its development link ("libEGL.so",
   which some ctypes loaders try first). */
static int hidden(const char *path) {
    const char *list = getenv("RIO_HIDDEN_LIBRARIES"), *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    size_t n = strlen(base);
    while (list && *list) {
        const char *end = strchr(list, ':');
        size_t len = end ? (size_t)(end - list) : strlen(list);
        const char *so = strstr(list, ".so");
        size_t stem = (so && so < list + len) ? (size_t)(so - list) + 3 : len;
        if ((len == n || stem == n) && strncmp(list, base, n) == 0) return 1;
        list = end ? end + 1 : NULL;
    }
    return 0;
}

/* Called with the name asked for (LA_SER_ORIG), then with each candidate path. A hidden candidate is
   swapped for a path that does not exist, not refused (NULL): the loader's own open then fails with
   ENOENT and the search goes on, so it ends as for an absent file, with the usual error ("...: cannot
   open shared object file: No such file or directory"; a refusal leaves errno as it was). */
char *la_objsearch(const char *name, uintptr_t *cookie, unsigned int flag) {
    (void)cookie;
    return (flag != LA_SER_ORIG && hidden(name)) ? (char *)"/nonexistent/rio-hidden-library" : (char *)name;
}
"""


def audit_library(workdir: str | os.PathLike[str]) -> Path:
    """The compiled audit library in `workdir` (compiled once there). Raises RuntimeError with the
    compiler's output when it cannot be built."""
    out = Path(workdir) / "rio-hide-libraries.so"
    if out.exists():
        return out
    src = out.with_suffix(".c")
    src.write_text(_SOURCE)
    r = subprocess.run(["cc", "-shared", "-fPIC", "-O2", "-o", str(out), str(src)], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"could not compile the audit library {src}: {r.stderr.strip()}")
    return out


def hide_libraries_env(sonames: Iterable[str], workdir: str | os.PathLike[str],
                       env: Mapping[str, str] | None = None) -> dict[str, str]:
    """`env` (default: this process's environment) for a child process that cannot load `sonames`
    ("libusb-1.0.so.0", ...). Linux with glibc only; the audit library is built in `workdir`."""
    names = list(sonames)
    if any(not n or "/" in n or ":" in n for n in names):
        raise ValueError(f"sonames are file names without ':' or '/': {names}")
    out = dict(os.environ if env is None else env)
    audit = str(audit_library(workdir))
    audits = [a for a in out.get("LD_AUDIT", "").split(":") if a]
    out["LD_AUDIT"] = ":".join(audits if audit in audits else [*audits, audit])
    out[HIDDEN_VAR] = ":".join(filter(None, [out.get(HIDDEN_VAR), *names]))
    return out
