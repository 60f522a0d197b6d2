// libFuzzer target on the scene reader: any bytes go through parseScene and the budget estimate. A scene
// that is not usable must end in SceneError; anything else (a crash, a hang, a sanitizer report, another
// exception) is a finding. Built and run by tools/fuzz.sh with clang's -fsanitize=fuzzer,address,undefined.
#include <cstddef>
#include <cstdint>
#include <string>

#include "io/SceneBudget.h"
#include "io/SceneReader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        const mpm::SceneDesc scene = mpm::parseScene(text, "fuzz.json");
        (void)mpm::estimateBudget(scene, false);
    } catch (const mpm::SceneError&) {}
    return 0;
}
