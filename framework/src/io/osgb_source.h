// Internal to the OSGB format: what read() keeps for write() (see texdefrag/io/osgb.h).
#pragma once

#include "texdefrag/io/model_format.h"

#include <osg/Geometry>
#include <osg/Image>
#include <osg/Node>
#include <osg/Texture>

#include <array>
#include <cstdint>
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

/// Index `i` of a primitive set's index list (DrawArrays: first + i).
inline uint32_t index_at(const osg::PrimitiveSet& ps, uint32_t i) { return ps.index(i); }

}  // namespace texdefrag::osgb_detail
