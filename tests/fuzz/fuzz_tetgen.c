// libFuzzer harness: the TetGen reader (.node + .ele). An input is the
// .node text, a line "---", then the .ele text (no "---": all .node, empty
// .ele). Its last byte's low bit sets fix_orientation. A mesh that loads
// must be whole (fuzz_check_mesh); a refusal must say why in printable
// text. ASan, UBSan and leak checks do the rest.
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static const char sep[] = "\n---\n";
  size_t node_len = size, ele_start = size;
  for (size_t i = 0; i + sizeof sep - 1 <= size; i++)
    if (memcmp(data + i, sep, sizeof sep - 1) == 0) {
      node_len = i + 1; // keep the node part's last newline
      ele_start = i + sizeof sep - 1;
      break;
    }
  char node[300], ele[300], base[300];
  fuzz_write(fuzz_path("m.node", node, sizeof node), data, node_len);
  fuzz_write(fuzz_path("m.ele", ele, sizeof ele), data + ele_start, size - ele_start);
  fuzz_path("m", base, sizeof base);
  ek_mesh_opts opts = {.fix_orientation = size ? data[size - 1] & 1 : 0};
  ek_mesh *m = ek_mesh_load_ex(base, &opts);
  if (m)
    fuzz_check_mesh(m);
  else
    fuzz_check_message(ek_last_error());
  ek_mesh_destroy(m);
  return 0;
}
