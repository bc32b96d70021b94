#include "ros/node/params.hpp"

#include <xmlrpcpp/XmlRpcValue.h>

#include <iomanip>
#include <limits>
#include <sstream>

#include "chungs/common/error.hpp"

namespace chungs::ros_node {

namespace {

// The configuration's top-level sections, as `diskchungs info --config` prints them.
const char* const kSections[] = {"store", "keyframes", "residency", "culling",  "raster", "loss", "adam",
                                 "prune", "mapper",    "sampler",   "selector", "stereo", "sky"};

// Flow-style YAML of one parameter value (strings quoted, so "1e-3" stays what the user typed).
void write_value(std::ostringstream& os, XmlRpc::XmlRpcValue& v, const std::string& name) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      os << (bool(v) ? "true" : "false");
      break;
    case XmlRpc::XmlRpcValue::TypeInt:
      os << int(v);
      break;
    case XmlRpc::XmlRpcValue::TypeDouble:
      os << std::setprecision(std::numeric_limits<double>::max_digits10) << double(v);
      break;
    case XmlRpc::XmlRpcValue::TypeString: {
      std::string s = v;
      os << '"';
      for (char c : s) os << (c == '"' || c == '\\' ? "\\" : "") << c;
      os << '"';
      break;
    }
    case XmlRpc::XmlRpcValue::TypeArray:
      os << '[';
      for (int i = 0; i < v.size(); ++i) {
        if (i) os << ", ";
        write_value(os, v[i], name);
      }
      os << ']';
      break;
    case XmlRpc::XmlRpcValue::TypeStruct: {
      os << '{';
      bool first = true;
      for (auto& [key, child] : v) {
        os << (first ? "" : ", ") << key << ": ";
        write_value(os, child, name + "/" + key);
        first = false;
      }
      os << '}';
      break;
    }
    default:
      fail("ROS parameter ", name, ": a value of this type cannot be a mapper setting");
  }
}

}  // namespace

std::string settings_yaml(const ros::NodeHandle& nh) {
  std::ostringstream os;
  for (const char* section : kSections) {
    XmlRpc::XmlRpcValue v;
    if (!nh.getParam(section, v)) continue;
    if (v.getType() != XmlRpc::XmlRpcValue::TypeStruct)
      fail("ROS parameter ", nh.resolveName(section), ": expected a map of settings (e.g. ", section,
           "/KEY)");
    os << section << ": ";
    write_value(os, v, nh.resolveName(section));
    os << "\n";
  }
  return os.str();
}

}  // namespace chungs::ros_node
