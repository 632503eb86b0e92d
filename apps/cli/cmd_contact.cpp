// placeholder
#include "cli_common.h"
namespace socketsmith::cli {
void register_contact(CLI::App&) {}
}
