// Internal to the OSGB format: what read() keeps for write() (see texdefrag/io/osgb.h).
#pragma once

#include "texdefrag/io/model_format.h"
#include "texdefrag/io/osgb.h"

#include <osg/Geometry>
#include <osg/Image>
#include <osg/Node>
#include <osg/Texture>

#include <array>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

namespace texdefrag::osgb_detail {

/// One osg::Geometry of the model.
struct GeometryRecord {
  osg::ref_ptr<osg::Geometry> geometry;
  osg::ref_ptr<osg::Texture> texture;  ///< unit-0 texture in force (null when untextured)
  int page = kNoPage;                  ///< input page of the texture's image
  size_t first_face = 0, num_faces = 0;
};

/// Where a face of the mesh comes from.
struct FaceRecord {
  uint32_t geometry = 0;                ///< index into OsgbSource::geometries
  uint32_t primitive_set = 0;           ///< index into the geometry's primitive set list
  std::array<uint32_t, 3> occurrence{}; ///< position of each corner in the set's index list
};

class OsgbSource : public ModelSource {
 public:
  osg::ref_ptr<osg::Node> root;
  std::vector<GeometryRecord> geometries;
  std::vector<FaceRecord> faces;                 ///< one per mesh face
  std::vector<osg::ref_ptr<osg::Image>> images;  ///< one per page
  std::string folder;                            ///< folder of the input file (as osgDB sets database paths)
};

/// Held around every osgDB read and write of the OSGB format (read_node, the writer), so that no
/// other thread of this process is inside osgDB (holding one of its locks) when
/// read_in_bounded_child forks.
std::mutex& osgdb_mutex();

/// osgb_read_limits(file_bytes), or the limits set by set_osgb_read_limits.
OsgbReadLimits limits_for(uint64_t file_bytes);

/// Reads `path` with osgDB in a child process under `limits` (texdefrag/io/osgb.h). Returns when
/// the child read a node; otherwise throws FormatError naming the file: osgDB's own message, or
/// the limit exceeded (memory, CPU time, wall time), or the signal that ended the child. Call it
/// with osgdb_mutex() held.
void read_in_bounded_child(const std::string& path, const OsgbReadLimits& limits);

/// Index `i` of a primitive set's index list (DrawArrays: first + i).
inline uint32_t index_at(const osg::PrimitiveSet& ps, uint32_t i) { return ps.index(i); }

}  // namespace texdefrag::osgb_detail
