// LeakSanitizer's built-in suppressions for third-party code, for
// FURN_SANITIZE=address builds. Include in exactly one file of each
// executable (its main): LeakSanitizer calls this at exit, so every test and
// every workbench process the tests start is covered, whatever environment
// ctest hands it (the Embree ISA variants set their own).
#pragma once

#if defined(__SANITIZE_ADDRESS__)
// Mesa's OSMesaMakeCurrent keeps a small per-context allocation (480 bytes)
// alive at exit.
extern "C" const char* __lsan_default_suppressions() { return "leak:libOSMesa.so\n"; }
#endif
