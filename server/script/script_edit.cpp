// The edit-script grammar: tokenising, parsing, formatting and the settings keywords.
#include "server/script/script_edit.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "common/core/printable_text.h"
#include "common/scene/scene_files.h"

namespace rtpm::server {

namespace {

// Tokenised line with positions for error messages.
class LineParser {
public:
    LineParser(std::string_view line, const std::string& file, int lineNo) : file_(file), lineNo_(lineNo) {
        std::string cur;
        for (char c : line) {
            if (c == '#') break;
            if (std::isspace(static_cast<unsigned char>(c))) {
                if (!cur.empty()) tokens_.push_back(std::move(cur));
                cur.clear();
            } else {
                cur += c;
            }
        }
        if (!cur.empty()) tokens_.push_back(std::move(cur));
    }
    bool empty() const { return tokens_.empty(); }
    bool done() const { return pos_ >= tokens_.size(); }
    [[noreturn]] void fail(const std::string& msg) const {
        throw SceneError(file_, "line " + std::to_string(lineNo_), msg);
    }
    std::string word(const char* what) {
        if (done()) fail(std::string("expected ") + what + " at end of line");
        return tokens_[pos_++];
    }
    float number(const char* what) {
        std::string t = word(what);
        size_t used = 0;
        float v = 0.0f;
        try {
            v = std::stof(t, &used);
        } catch (const std::exception&) {
            fail(std::string("expected a number for ") + what + ", got '" + printableText(t) + "'");
        }
        if (used != t.size() || !std::isfinite(v))
            fail(std::string("expected a finite number for ") + what + ", got '" + printableText(t) + "'");
        return v;
    }
    uint64_t integer(const char* what) {
        std::string t = word(what);
        if (t.empty() || t.size() > 18 || !std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; }))
            fail(std::string("expected a non-negative integer for ") + what + ", got '" + printableText(t) + "'");
        return std::stoull(t);
    }
    Vec3 vec3(const char* what) {
        float x = number(what), y = number(what), z = number(what);
        return Vec3(x, y, z);
    }

private:
    std::string file_;
    int lineNo_;
    std::vector<std::string> tokens_;
    size_t pos_ = 0;
};

template <class T>
void setOnce(LineParser& p, std::optional<T>& slot, T value, const std::string& key) {
    if (slot) p.fail("'" + key + "' given twice");
    slot = value;
}

// `settings` keywords: one per live knob, its value a number or a choice name (limits are checked
// when the edit is applied, with the rest of the settings).
void setKnob(LineParser& p, ScriptEdit& e, const std::string& key) {
    for (const KnobRow& row : kKnobs) {
        if (key != row.scriptKey) continue;
        std::optional<double>& slot = e.settings[size_t(row.id)];
        if (slot) p.fail("'" + key + "' given twice");
        const std::string text = p.word(row.isChoice() ? "a name" : "a number");
        slot = parseKnobValue(row, text);
        if (!slot)
            p.fail((row.isChoice() ? "unknown " : "expected a number for ") + std::string(row.name) + " '" +
                   printableText(text) + "' (expected " + knobRange(row) + ")");
        return;
    }
    p.fail("unknown keyword '" + printableText(key) + "' for a settings edit");
}

std::string lineEl(int line) { return line > 0 ? "line " + std::to_string(line) : "edit"; }

[[noreturn]] void fail(const std::string& file, int line, const std::string& msg) {
    throw SceneError(file, lineEl(line), msg);
}

}  // namespace

std::vector<ScriptEdit> parseEditScript(std::string_view text, const std::string& fileName) {
    std::vector<ScriptEdit> edits;
    int lineNo = 0;
    size_t start = 0;
    while (start <= text.size()) {
        size_t end = text.find('\n', start);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(start, end - start);
        start = end + 1;
        ++lineNo;
        LineParser p(line, fileName, lineNo);
        if (p.empty()) {
            if (end == text.size()) break;
            continue;
        }
        ScriptEdit e;
        e.line = lineNo;
        if (p.word("'frame'") != "frame") p.fail("a line must start with 'frame <n>'");
        e.frame = p.integer("the frame number");
        std::string kind = p.word("camera, light, material or transform");
        if (kind == "camera") {
            e.kind = ScriptEdit::Kind::Camera;
        } else if (kind == "light") {
            e.kind = ScriptEdit::Kind::Light;
        } else if (kind == "material") {
            e.kind = ScriptEdit::Kind::Material;
        } else if (kind == "transform") {
            e.kind = ScriptEdit::Kind::Transform;
        } else if (kind == "settings") {
            e.kind = ScriptEdit::Kind::Settings;
        } else {
            p.fail("unknown edit '" + printableText(kind) + "' (expected camera, light, material, transform or settings)");
        }
        if (e.kind != ScriptEdit::Kind::Camera && e.kind != ScriptEdit::Kind::Settings) {
            uint64_t i = p.integer("the index");
            if (i > 0xffffffffull) p.fail("index too large");
            e.index = static_cast<uint32_t>(i);
        }
        bool any = false;
        while (!p.done()) {
            std::string key = p.word("a keyword");
            any = true;
            using K = ScriptEdit::Kind;
            if (e.kind == K::Camera && key == "eye") setOnce(p, e.camera.eye, p.vec3("eye"), key);
            else if (e.kind == K::Camera && key == "target") setOnce(p, e.camera.target, p.vec3("target"), key);
            else if (e.kind == K::Camera && key == "yfov") setOnce(p, e.camera.yfov, p.number("yfov"), key);
            else if (e.kind == K::Light && key == "position") setOnce(p, e.light.position, p.vec3("position"), key);
            else if (e.kind == K::Light && key == "direction") setOnce(p, e.light.direction, p.vec3("direction"), key);
            else if (e.kind == K::Light && key == "intensity") setOnce(p, e.light.intensity, p.vec3("intensity"), key);
            else if (e.kind == K::Material && key == "type") {
                std::string t = p.word("diffuse, mirror, dielectric or plastic");
                MaterialType mt = MaterialType::Diffuse;
                if (t == "diffuse") mt = MaterialType::Diffuse;
                else if (t == "mirror") mt = MaterialType::Mirror;
                else if (t == "dielectric") mt = MaterialType::Dielectric;
                else if (t == "plastic") mt = MaterialType::Plastic;
                else p.fail("unknown material type '" + printableText(t) + "' (expected diffuse, mirror, dielectric or plastic)");
                setOnce(p, e.material.type, mt, key);
            } else if (e.kind == K::Material && key == "color") setOnce(p, e.material.color, p.vec3("color"), key);
            else if (e.kind == K::Material && key == "ior") setOnce(p, e.material.ior, p.number("ior"), key);
            else if (e.kind == K::Material && key == "absorption") setOnce(p, e.material.absorption, p.vec3("absorption"), key);
            else if (e.kind == K::Material && key == "emission") setOnce(p, e.material.emission, p.vec3("emission"), key);
            else if (e.kind == K::Transform && key == "translate") setOnce(p, e.transform.translate, p.vec3("translate"), key);
            else if (e.kind == K::Transform && key == "rotate") {
                Vec3 axis = p.vec3("rotate axis");
                float deg = p.number("rotate degrees");
                setOnce(p, e.transform.rotate, glm::vec4(axis, deg), key);
            } else if (e.kind == K::Transform && key == "scale") setOnce(p, e.transform.scale, p.number("scale"), key);
            else if (e.kind == K::Transform && key == "matrix") {
                Mat4 m(1.0f);
                for (int c = 0; c < 4; ++c)
                    for (int r = 0; r < 4; ++r) m[c][r] = p.number("matrix");
                setOnce(p, e.transform.matrix, m, key);
            } else if (e.kind == K::Settings) {
                setKnob(p, e, key);
            } else {
                p.fail("unknown keyword '" + printableText(key) + "' for a " + kind + " edit");
            }
        }
        if (!any) p.fail("a " + kind + " edit needs at least one keyword");
        if (e.transform.matrix && (e.transform.translate || e.transform.rotate || e.transform.scale))
            p.fail("'matrix' cannot be combined with translate, rotate or scale");
        if (e.transform.rotate && glm::length(Vec3(*e.transform.rotate)) == 0.0f) p.fail("rotate axis is zero");
        if (e.transform.scale && !(*e.transform.scale > 0.0f)) p.fail("scale must be > 0");
        if (e.camera.yfov && !(*e.camera.yfov > 0.0f && *e.camera.yfov < kPi)) p.fail("yfov must be in (0, pi) radians");
        if (edits.size() >= kMaxScriptEdits)
            p.fail("more than " + std::to_string(kMaxScriptEdits) + " edits in one script");
        edits.push_back(e);
        if (end == text.size()) break;
    }
    std::stable_sort(edits.begin(), edits.end(),
                     [](const ScriptEdit& a, const ScriptEdit& b) { return a.frame < b.frame; });
    return edits;
}

std::vector<ScriptEdit> loadEditScript(const std::string& path) {
    // Regular files only (a FIFO or /dev/zero would block or never end), size checked first.
    const std::vector<uint8_t> bytes = readRegularFile(path, path, "file", [&](uint64_t size) {
        if (size > kMaxScriptBytes)
            throw SceneError(path, "file", "edit script of " + std::to_string(size) +
                                               " bytes is larger than the " +
                                               std::to_string(kMaxScriptBytes) + "-byte limit");
    });
    return parseEditScript(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), path);
}

std::string formatScriptEdit(const ScriptEdit& e) {
    std::ostringstream o;
    o.imbue(std::locale::classic());
    o.precision(9);
    auto v3 = [&](const char* key, const std::optional<Vec3>& v) {
        if (v) o << ' ' << key << ' ' << v->x << ' ' << v->y << ' ' << v->z;
    };
    using K = ScriptEdit::Kind;
    o << "frame " << e.frame << ' ';
    switch (e.kind) {
        case K::Camera: o << "camera"; break;
        case K::Light: o << "light " << e.index; break;
        case K::Material: o << "material " << e.index; break;
        case K::Transform: o << "transform " << e.index; break;
        case K::Settings: o << "settings"; break;
    }
    v3("eye", e.camera.eye);
    v3("target", e.camera.target);
    if (e.camera.yfov) o << " yfov " << *e.camera.yfov;
    v3("position", e.light.position);
    v3("direction", e.light.direction);
    v3("intensity", e.light.intensity);
    if (e.material.type)
        o << " type "
          << materialTypeName(*e.material.type);
    v3("color", e.material.color);
    if (e.material.ior) o << " ior " << *e.material.ior;
    v3("absorption", e.material.absorption);
    v3("emission", e.material.emission);
    v3("translate", e.transform.translate);
    if (e.transform.rotate) o << " rotate " << e.transform.rotate->x << ' ' << e.transform.rotate->y << ' ' << e.transform.rotate->z << ' ' << e.transform.rotate->w;
    if (e.transform.scale) o << " scale " << *e.transform.scale;
    if (e.transform.matrix) {
        o << " matrix";
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) o << ' ' << (*e.transform.matrix)[c][r];
    }
    for (const KnobRow& row : kKnobs)
        if (const auto& v = e.settings[size_t(row.id)]) o << ' ' << row.scriptKey << ' ' << formatKnobValue(row, *v);
    return o.str();
}

void applySettingsEdit(const ScriptEdit& e, const std::string& file, RenderSettings& settings) {
    RenderSettings s = settings;
    for (const KnobRow& row : kKnobs)
        if (const auto& v = e.settings[size_t(row.id)]) {
            // Checked before it is stored: a value the field cannot hold must not wrap into range.
            if (auto error = knobValueError(row, *v)) fail(file, e.line, "settings refused: " + *error);
            row.set(s, *v);
        }
    try {
        validateSettings(s);
    } catch (const std::invalid_argument& ex) {
        fail(file, e.line, std::string("settings refused: ") + ex.what());
    }
    settings = s;
}

}  // namespace rtpm::server
