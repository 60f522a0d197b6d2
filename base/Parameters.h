#pragma once
// How a material, a shape or a set of settings names its scene keys. Each such type has one function,
// `keys(v, value)`, that hands every field to a visitor together with its key, range, unit and help text;
// the value's initial content is the default. The scene reader, `mpm validate --explain` (and so
// docs/scene-format.md) and the benchmark presets all walk that one function, so a key, its default and its
// documentation cannot drift apart. A visitor has this shape (KeyVisitorArchetype below is one):
// @code
// struct Visitor {
//     template <class T> void number(const Key&, T& value);    // float or double
//     template <class T> void integer(const Key&, T& value);   // int, long long, unsigned
//     void flag(const Key&, bool& value);
//     template <class T> void vec3(const Key&, Eigen::Matrix<T, 3, 1>& value);  // Vec3d or Vec3f
//     void text(const Key&, std::string& value);
//     template <class E> void choice(const Key&, E& value, std::span<const Named<E>> names);  // an enum
//     void choice(const Key&, std::string& value, const std::vector<std::string>& allowed);
//     void choices(const Key&, std::vector<std::string>& values, const std::vector<std::string>& allowed);  // a list of names
//     void check(bool ok, std::string_view key, const std::string& problem);  // a rule between keys
//     bool given(std::string_view key);                                       // whether the scene has it
//     template <class F> void object(const Key&, F&& f);                     // f(visitor&) inside a nested object
//     template <class T, class F> void list(const Key&, std::vector<T>&, F&& f);  // f(visitor&, T&) per element
// };
// @endcode
#include <initializer_list>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/Types.h"

namespace mpm {

/// The widest range most physical quantities accept: above zero, below 1e12 (in SI units).
inline constexpr double kTiny = 1e-12;
inline constexpr double kHuge = 1e12;

/// One scene key: its name, what it means, its range (numbers and integers), unit, and whether it must be given.
struct Key {
    std::string_view name;
    std::string_view help;
    double lo = -std::numeric_limits<double>::infinity();
    double hi = std::numeric_limits<double>::infinity();
    std::string_view unit = "";
    bool required = false;
    std::string_view noun = "value";  ///< what a choice picks, for "unknown <noun>" messages
    /// A default that is no constant ("its centre", "the material's"): the documentation shows this instead.
    std::string_view byDefault = "";
    /// Not given, its value is derived when the scene is built (from a shape's bounds, from the particles): the
    /// resolved scene leaves it out until the builder writes the value it derived (io/SceneBuilder.h).
    bool derived = false;
};

/// A name for one value of an enumeration.
template <class E>
struct Named {
    E value;
    const char* name;
};

/// A visitor that does nothing: the concept checks below call keys() with it.
struct KeyVisitorArchetype {
    template <class T>
    void number(const Key&, T&) {}
    template <class T>
    void integer(const Key&, T&) {}
    void flag(const Key&, bool&) {}
    template <class T>
    void vec3(const Key&, Eigen::Matrix<T, 3, 1>&) {}
    void text(const Key&, std::string&) {}
    template <class E>
    void choice(const Key&, E&, std::span<const Named<E>>) {}
    void choice(const Key&, std::string&, const std::vector<std::string>&) {}
    void choices(const Key&, std::vector<std::string>&, const std::vector<std::string>&) {}
    void check(bool, std::string_view, const std::string&) {}
    bool given(std::string_view) { return false; }
    template <class F>
    void object(const Key&, F&& f) {
        f(*this);
    }
    template <class T, class F>
    void list(const Key&, std::vector<T>& items, F&& f) {
        for (T& item : items) f(*this, item);
    }
};

/// Whether the names a list gives its members (materials' kSceneName, shapes' kType) all differ: a scene picks a
/// member by its name.
constexpr bool namesDistinct(std::initializer_list<std::string_view> names) {
    for (auto a = names.begin(); a != names.end(); ++a)
        for (auto b = a + 1; b != names.end(); ++b)
            if (*a == *b) return false;
    return true;
}

/// A type that describes its scene keys.
template <class T>
concept HasSceneKeys = requires(KeyVisitorArchetype& v, T& value) {
    T::keys(v, value);
};

}  // namespace mpm
