#include "core/Species.h"

namespace mpm {

const std::vector<std::string>& materialSceneNames() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> v;
        forEachMaterial(AllMaterials{}, [&]<class M>() { v.push_back(M::kSceneName); });
        return v;
    }();
    return names;
}

bool defaultMaterialParams(const std::string& sceneName, AnyMaterialParams& out) {
    bool found = false;
    forEachMaterial(AllMaterials{}, [&]<class M>() {
        if (!found && sceneName == M::kSceneName) {
            out = typename M::Params{};
            found = true;
        }
    });
    return found;
}

bool defaultMaterialParamsAt(std::size_t index, AnyMaterialParams& out) {
    std::size_t k = 0;
    bool found = false;
    forEachMaterial(AllMaterials{}, [&]<class M>() {
        if (k++ == index) {
            out = typename M::Params{};
            found = true;
        }
    });
    return found;
}

}  // namespace mpm
