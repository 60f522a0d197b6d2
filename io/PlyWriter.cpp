#include "io/PlyWriter.h"

#include <cstring>
#include <fstream>
#include <stdexcept>

#include "io/AtomicFile.h"

namespace mpm {

void writePly(const std::string& path, const PointCloud& f) {
    writeAtomically(path, [&](std::ostream& out) {
        out << "ply\nformat binary_little_endian 1.0\ncomment sparse-mpm particles, SI units\nelement vertex " << f.size()
            << "\nproperty float x\nproperty float y\nproperty float z\nproperty float vx\nproperty float vy\n"
               "property float vz\nproperty int id\nend_header\n";
        struct Record {
            float x[3], v[3];
            int32_t id;
        };
        static_assert(sizeof(Record) == 28, "PLY record must be packed");
        std::vector<Record> buf(f.size());
        for (std::size_t i = 0; i < f.size(); ++i) {
            for (int a = 0; a < 3; ++a) {
                buf[i].x[a] = float(f.x[i][a]);
                buf[i].v[a] = f.v[i][a];
            }
            buf[i].id = f.id[i];
        }
        out.write(reinterpret_cast<const char*>(buf.data()), std::streamsize(buf.size() * sizeof(Record)));
    });
}

}  // namespace mpm
