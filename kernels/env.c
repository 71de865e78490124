// The EK_* environment variables the library reads, one rule for all: unset
// or empty is the default; any other value must be one of the variable's
// words, exactly (EK_ISA's convention: "EK_ISA='x' is not one of scalar,
// avx2, avx512"). The library never exits: a bad value is an error through
// ek_set_error where it is read (a tuning then keeps its default), and
// ek_env_check lets a program refuse it before it starts.
#include <ek/core.h>

#include <stdlib.h>
#include <string.h>

#include "kernels.h"

int ek_env_choice(const char *name, int n, const char *const *words, int *index) {
  const char *v = getenv(name);
  if (!v || !*v)
    return 0;
  for (int i = 0; i < n; i++)
    if (strcmp(v, words[i]) == 0) {
      *index = i;
      return 1;
    }
  char list[128] = "";
  for (int i = 0; i < n; i++) {
    strncat(list, i ? ", " : "", sizeof list - strlen(list) - 1);
    strncat(list, words[i], sizeof list - strlen(list) - 1);
  }
  ek_set_error("%s='%s' is not one of %s", name, v, list);
  return EK_EINVAL;
}

int ek_env_verbose(void) {
  // Read on every error, so by hand: ek_env_choice would report a bad value
  // through ek_set_error, which reads this. A bad value is off here;
  // ek_env_check reports it.
  const char *v = getenv("EK_VERBOSE");
  return v && strcmp(v, "1") == 0;
}

int ek_env_check(void) {
  static const char *const bits[] = {"0", "1"}, *const chains[] = {"2", "4"},
                           *const isas[] = {"scalar", "avx2", "avx512"};
  static const struct {
    const char *name;
    int n;
    const char *const *words;
  } vars[] = {
      {"EK_ISA", 3, isas},
      {"EK_VERBOSE", 2, bits},
      {"EK_SVD3_CHAINS", 2, chains},
      {"EK_FVM_PREFETCH", 2, bits},
  };
  for (size_t k = 0; k < sizeof vars / sizeof vars[0]; k++) {
    int index;
    int rc = ek_env_choice(vars[k].name, vars[k].n, vars[k].words, &index);
    if (rc < 0)
      return rc;
  }
  return EK_OK;
}
