#include "geo/export.hpp"

#include <cerrno>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <system_error>
#include <utility>

#include <cpl_json.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal_version.h>
#include <ogrsf_frmts.h>

#include "geo/gdal_support.hpp"

namespace gis::geo {

namespace {

constexpr const char* kSelectionLayer = "selection_layer";
constexpr const char* kSelectionFid = "selection_fid";

/// GDAL's GeoJSON driver writes a string that starts and ends with [] or {} and parses as JSON
/// as that JSON (an array or object, no longer a string). AUTODETECT_JSON_STRINGS=NO (GDAL 3.8)
/// stops that; before, we can only warn.
constexpr bool kDriverCanKeepJsonLikeStrings = GDAL_VERSION_NUM >= GDAL_COMPUTE_VERSION(3, 8, 0);

/// Layer creation options common to both exports.
CPLStringList layerOptions() {
  CPLStringList options;
  options.SetNameValue("WRITE_NAME", "YES");
  options.SetNameValue("WRITE_BBOX", "NO");
  if (kDriverCanKeepJsonLikeStrings) options.SetNameValue("AUTODETECT_JSON_STRINGS", "NO");
  return options;
}

Diagnostic error(const std::string& file, const std::string& layer, const std::string& message,
                 const std::string& feature = "") {
  return {Severity::Error, file, layer, feature, message};
}

/// One output field. GeoJSON has no schema, so width and precision only matter to GDAL while writing.
struct FieldSpec {
  std::string name;
  OGRFieldType type = OFTString;
  OGRFieldSubType subType = OFSTNone;
  int width = 0;
  int precision = 0;
};

/// The output fields in first-seen order, by case-sensitive name (GeoJSON property names are).
/// A name added again with another type becomes Integer64 when both are integers, else String.
class Schema {
 public:
  void add(const FieldSpec& field) {
    const int i = index(field.name);
    if (i < 0) {
      fields_.push_back(field);
      return;
    }
    FieldSpec& f = fields_[static_cast<std::size_t>(i)];
    if (f.type == field.type) {
      if (f.subType != field.subType) f.subType = OFSTNone;
      return;
    }
    const auto isInteger = [](OGRFieldType t) { return t == OFTInteger || t == OFTInteger64; };
    f.type = isInteger(f.type) && isInteger(field.type) ? OFTInteger64 : OFTString;
    f.subType = OFSTNone;
    f.width = 0;
    f.precision = 0;
  }

  void add(const OGRFieldDefn& defn) {
    add({defn.GetNameRef(), defn.GetType(), defn.GetSubType(), defn.GetWidth(), defn.GetPrecision()});
  }

  [[nodiscard]] int index(const std::string& name) const {
    for (std::size_t i = 0; i < fields_.size(); ++i)
      if (fields_[i].name == name) return static_cast<int>(i);
    return -1;
  }

  [[nodiscard]] const std::vector<FieldSpec>& fields() const { return fields_; }

 private:
  std::vector<FieldSpec> fields_;
};

/// The types of the extra properties of a source's features (a null value says nothing).
void addExtraFields(const ExportSource& source, std::map<std::string, std::optional<OGRFieldType>>& types) {
  for (const ExportedFeature& f : source.features) {
    for (const auto& [name, value] : f.extra) {
      std::optional<OGRFieldType>& type = types[name];
      if (std::holds_alternative<std::monostate>(value)) continue;
      const OGRFieldType seen = std::holds_alternative<std::int64_t>(value) ? OFTInteger64
                                : std::holds_alternative<double>(value)     ? OFTReal
                                                                            : OFTString;
      type = !type || *type == seen ? seen : OFTString;
    }
  }
}

void addExtraFields(const std::map<std::string, std::optional<OGRFieldType>>& types, Schema& schema) {
  for (const auto& [name, type] : types) schema.add(FieldSpec{name, type.value_or(OFTString)});
}

/// An opened source layer and what is needed to copy its features.
struct OpenedSource {
  const ExportSource* source = nullptr;
  GDALDatasetUniquePtr ds;
  OGRLayer* layer = nullptr;
  std::string layerName;
  detail::SrsPtr srs;  ///< traditional axis order; null when neither the file nor assumedCrs gives one
  std::unique_ptr<OGRCoordinateTransformation> toWgs84;  ///< combined export only
};

/// Opens the source layer; nullopt with an error in `d` when that fails.
std::optional<OpenedSource> openSource(const ExportSource& source, Diagnostics& d) {
  OpenedSource s;
  s.source = &source;
  CPLErrorReset();
  s.ds.reset(GDALDataset::FromHandle(GDALOpenEx(
      source.path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr, nullptr, nullptr)));
  if (!s.ds) {
    d.add(error(source.path, source.layer,
                "cannot open as vector data: " + detail::QuietGdal::lastMessage("not a vector format OGR can read")));
    return std::nullopt;
  }
  s.layer = source.layer.empty() ? (s.ds->GetLayerCount() > 0 ? s.ds->GetLayer(0) : nullptr)
                                 : s.ds->GetLayerByName(source.layer.c_str());
  if (s.layer == nullptr) {
    d.add(error(source.path, source.layer, source.layer.empty() ? "the data source has no layers" : "no such layer"));
    return std::nullopt;
  }
  s.layerName = s.layer->GetName();
  if (const OGRSpatialReference* srs = s.layer->GetSpatialRef(); srs != nullptr && !srs->IsEmpty()) {
    s.srs = detail::cloneTraditional(*srs);
  } else if (!source.assumedCrs.empty()) {
    std::string message;
    s.srs = detail::parseSrs(source.assumedCrs, message);
    if (!s.srs) {
      d.add(error(source.path, s.layerName, "the layer has no CRS and the assumed CRS is bad: " + message));
      return std::nullopt;
    }
  }
  return s;
}

/// The feature label used in diagnostics and "selection_layer".
std::string labelOf(const OpenedSource& s) { return s.source->label.empty() ? s.layerName : s.source->label; }

/// Warns once per name when an exported property replaces an original attribute.
void warnReplacedAttributes(const OpenedSource& s, const std::set<std::string>& added, Diagnostics& d) {
  const OGRFeatureDefn* defn = s.layer->GetLayerDefn();
  for (int i = 0; i < defn->GetFieldCount(); ++i) {
    const std::string name = defn->GetFieldDefn(i)->GetNameRef();
    if (added.count(name) != 0)
      d.add({Severity::Warning, s.source->path, s.layerName, "",
             "the exported property '" + name + "' replaces the original attribute of the same name"});
  }
}

std::set<std::string> extraNames(const ExportSource& source) {
  std::set<std::string> names;
  for (const ExportedFeature& f : source.features)
    for (const auto& entry : f.extra) names.insert(entry.first);
  return names;
}

/// Replaces an existing file and creates the GeoJSON data source; null with an error in `d`.
GDALDatasetUniquePtr createGeoJson(const std::string& outPath, Diagnostics& d) {
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GeoJSON");
  if (driver == nullptr) {
    d.add(error(outPath, "", "GDAL has no GeoJSON driver"));
    return nullptr;
  }
  // The GeoJSON driver refuses to overwrite a file.
  VSIStatBufL stat;
  if (VSIStatL(outPath.c_str(), &stat) == 0) {
    if (VSI_ISDIR(stat.st_mode)) {
      d.add(error(outPath, "", "cannot write the GeoJSON file: it is a directory"));
      return nullptr;
    }
    if (VSIUnlink(outPath.c_str()) != 0) {
      d.add(error(outPath, "",
                  "cannot replace the existing file: " + std::error_code(errno, std::generic_category()).message()));
      return nullptr;
    }
  }
  CPLErrorReset();
  GDALDatasetUniquePtr ds(driver->Create(outPath.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
  if (!ds)
    d.add(error(outPath, "", "cannot create the GeoJSON file: " + detail::QuietGdal::lastMessage("unknown error")));
  return ds;
}

/// True when writing `outPath` would destroy the source file.
bool isSameFile(const std::string& sourcePath, const std::string& outPath) {
  std::error_code ec;
  return std::filesystem::equivalent(sourcePath, outPath, ec) && !ec;
}

/// Creates the schema's fields; false with an error in `d` when the driver refuses one.
bool createFields(OGRLayer& layer, const Schema& schema, const std::string& outPath, Diagnostics& d) {
  for (const FieldSpec& f : schema.fields()) {
    OGRFieldDefn defn(f.name.c_str(), f.type);
    defn.SetSubType(f.subType);
    defn.SetWidth(f.width);
    defn.SetPrecision(f.precision);
    const int before = layer.GetLayerDefn()->GetFieldCount();
    if (layer.CreateField(&defn) != OGRERR_NONE || layer.GetLayerDefn()->GetFieldCount() != before + 1) {
      d.add(error(
          outPath, layer.GetName(),
          "cannot create the field '" + f.name + "': " + detail::QuietGdal::lastMessage("refused by the driver")));
      return false;
    }
  }
  return true;
}

void setValue(OGRFeature& out, int field, const AttributeValue& value) {
  if (const auto* i = std::get_if<std::int64_t>(&value)) {
    out.SetField(field, static_cast<GIntBig>(*i));
  } else if (const auto* x = std::get_if<double>(&value)) {
    out.SetField(field, *x);
  } else if (const auto* s = std::get_if<std::string>(&value)) {
    out.SetField(field, s->c_str());
  } else {
    out.SetFieldNull(field);
  }
}

/// Copies source field `from` into output field `to`, converting when the union changed the type.
void copyField(const OGRFeature& src, int from, OGRFeature& out, int to) {
  if (!src.IsFieldSet(from)) return;
  if (src.IsFieldNull(from)) {
    out.SetFieldNull(to);
    return;
  }
  const OGRFieldType fromType = src.GetFieldDefnRef(from)->GetType();
  const OGRFieldType toType = out.GetFieldDefnRef(to)->GetType();
  bool recoded = false;
  if (fromType == OFTString) {
    // As the reader gives it: UTF-8, Latin-1 recoded (detail::toUtf8).
    out.SetField(to, detail::toUtf8(src.GetFieldAsString(from), recoded).c_str());
  } else if (fromType == toType) {
    out.SetField(to, src.GetRawFieldRef(from));
  } else if (toType == OFTInteger64) {
    out.SetField(to, static_cast<GIntBig>(src.GetFieldAsInteger64(from)));
  } else {
    out.SetField(to, detail::toUtf8(src.GetFieldAsString(from), recoded).c_str());
  }
}

/// Names the String fields of `feature` whose value the driver would write as JSON (see
/// kDriverCanKeepJsonLikeStrings), each once per source (`warned`).
void warnJsonLikeStrings(const OGRFeature& feature, const OpenedSource& s, const std::string& fid,
                         std::set<std::string>& warned, Diagnostics& d) {
  if (kDriverCanKeepJsonLikeStrings) return;
  for (int i = 0; i < feature.GetFieldCount(); ++i) {
    if (feature.GetFieldDefnRef(i)->GetType() != OFTString || !feature.IsFieldSetAndNotNull(i)) continue;
    const std::string value = feature.GetFieldAsString(i);
    const bool bracketed = value.size() >= 2 && ((value.front() == '[' && value.back() == ']') ||
                                                 (value.front() == '{' && value.back() == '}'));
    const std::string name = feature.GetFieldDefnRef(i)->GetNameRef();
    if (!bracketed || warned.count(name) != 0 || !CPLJSONDocument().LoadMemory(value)) continue;
    warned.insert(name);
    d.add({Severity::Warning, s.source->path, s.layerName, fid,
           "the string attribute '" + name +
               "' looks like JSON and GDAL " GDAL_RELEASE_NAME
               " writes it as a JSON array or object, not as a string (this and later features)"});
  }
}

/// Copies the selected features of one source into `out`; `written` counts the features in `out`.
/// The FID becomes the GeoJSON feature "id". With `combined`, geometries are reprojected to
/// WGS 84, "selection_layer"/"selection_fid" are set and the "id" numbers the features of the
/// file: FIDs of several sources may clash, and without feature ids GDAL's reader would take an
/// integer "id" property of one source as FID column (duplicate FIDs).
void writeFeatures(const OpenedSource& s, OGRLayer& out, const Schema& schema, bool combined,
                   const std::string& outPath, std::int64_t& written, Diagnostics& d) {
  const OGRFeatureDefn* srcDefn = s.layer->GetLayerDefn();
  std::vector<int> outIndex(static_cast<std::size_t>(srcDefn->GetFieldCount()));
  for (int i = 0; i < srcDefn->GetFieldCount(); ++i)
    outIndex[static_cast<std::size_t>(i)] = schema.index(srcDefn->GetFieldDefn(i)->GetNameRef());
  const std::string label = labelOf(s);
  std::set<std::string> warnedJson;

  for (const ExportedFeature& selected : s.source->features) {
    const std::string fid = std::to_string(selected.fid);
    auto fail = [&](const std::string& message) { d.add(error(s.source->path, s.layerName, message, fid)); };
    CPLErrorReset();
    const OGRFeatureUniquePtr src(s.layer->GetFeature(static_cast<GIntBig>(selected.fid)));
    if (!src) {
      fail("no feature with this FID in the source");
      continue;
    }
    OGRFeatureUniquePtr feature(OGRFeature::CreateFeature(out.GetLayerDefn()));
    for (int i = 0; i < srcDefn->GetFieldCount(); ++i)
      if (const int to = outIndex[static_cast<std::size_t>(i)]; to >= 0) copyField(*src, i, *feature, to);
    if (combined) {
      feature->SetField(schema.index(kSelectionLayer), label.c_str());
      feature->SetField(schema.index(kSelectionFid), static_cast<GIntBig>(selected.fid));
      feature->SetFID(static_cast<GIntBig>(written));
    } else {
      feature->SetFID(src->GetFID());
    }
    for (const auto& [name, value] : selected.extra) setValue(*feature, schema.index(name), value);
    warnJsonLikeStrings(*feature, s, fid, warnedJson, d);

    if (const OGRGeometry* geometry = src->GetGeometryRef(); geometry != nullptr) {
      std::unique_ptr<OGRGeometry> copy;
      if (geometry->hasCurveGeometry()) {
        // GeoJSON has no arcs.
        copy.reset(geometry->getLinearGeometry());
        d.add({Severity::Warning, s.source->path, s.layerName, fid,
               "curve geometry written as line segments (GeoJSON has no arcs)"});
      } else {
        copy.reset(geometry->clone());
      }
      if (!copy) {
        fail("cannot copy the geometry");
        continue;
      }
      if (s.toWgs84 && copy->transform(s.toWgs84.get()) != OGRERR_NONE) {
        fail("cannot reproject the geometry to WGS 84: " + detail::QuietGdal::lastMessage("transformation failed"));
        continue;
      }
      feature->SetGeometryDirectly(copy.release());
    }
    if (out.CreateFeature(feature.get()) != OGRERR_NONE) {
      fail("cannot write to " + outPath + ": " + detail::QuietGdal::lastMessage("write error"));
      continue;
    }
    ++written;
  }
}

/// GDAL's GeoJSON driver writes a "crs" member only for a CRS with an authority code (its OGC
/// URN, e.g. urn:ogc:def:crs:EPSG::32725) and drops any other CRS without a word, after which
/// every reader assumes WGS 84. Returns nullopt when the driver's URN reads back as the same CRS,
/// else the WKT to write ourselves (empty if the CRS cannot be exported).
std::optional<std::string> ownCrsName(const OGRSpatialReference& srs) {
  char* urn = srs.GetOGCURN();
  bool driverWritesIt = false;
  if (urn != nullptr) {
    OGRSpatialReference back;
    back.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    driverWritesIt =
        back.SetFromUserInput(urn, OGRSpatialReference::SET_FROM_USER_INPUT_LIMITATIONS_get()) == OGRERR_NONE &&
        back.IsSame(&srs);
  }
  CPLFree(urn);
  if (driverWritesIt) return std::nullopt;
  return detail::toWkt(srs);
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += CPLSPrintf("\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
    } else {
      out += c;
    }
  }
  return out + '"';
}

/// Adds `"crs": {"type": "name", "properties": {"name": <name>}}` to a FeatureCollection written
/// by the GeoJSON driver (which starts with `{\n"type": "FeatureCollection",\n`). GDAL reads the
/// name with SetFromUserInput(), which takes WKT as well as URNs.
bool insertCrsMember(const std::string& path, const std::string& name) {
  GByte* data = nullptr;
  vsi_l_offset size = 0;
  if (!VSIIngestFile(nullptr, path.c_str(), &data, &size, -1)) return false;
  std::string text(reinterpret_cast<const char*>(data), static_cast<std::size_t>(size));
  VSIFree(data);
  const std::string head = "\"type\": \"FeatureCollection\",\n";
  const std::size_t at = text.find(head);
  if (at == std::string::npos || at > 8) return false;
  text.insert(at + head.size(),
              "\"crs\": { \"type\": \"name\", \"properties\": { \"name\": " + jsonString(name) + " } },\n");
  VSILFILE* fp = VSIFOpenL(path.c_str(), "wb");
  if (fp == nullptr) return false;
  const bool written = VSIFWriteL(text.data(), 1, text.size(), fp) == text.size();
  return VSIFCloseL(fp) == 0 && written;
}

}  // namespace

Diagnostics exportFeaturesGeoJson(const ExportSource& source, const std::string& outPath) {
  detail::ensureGdalRegistered();
  detail::QuietGdal quiet;
  Diagnostics d;
  std::optional<OpenedSource> s = openSource(source, d);
  if (!s) return d;
  if (isSameFile(source.path, outPath)) {
    d.add(error(outPath, s->layerName, "the output file is the source file"));
    return d;
  }

  Schema schema;
  const OGRFeatureDefn* defn = s->layer->GetLayerDefn();
  for (int i = 0; i < defn->GetFieldCount(); ++i) schema.add(*defn->GetFieldDefn(i));
  std::map<std::string, std::optional<OGRFieldType>> extraTypes;
  addExtraFields(source, extraTypes);
  addExtraFields(extraTypes, schema);
  warnReplacedAttributes(*s, extraNames(source), d);

  std::optional<std::string> ownCrs;
  if (s->srs) {
    ownCrs = ownCrsName(*s->srs);
    if (ownCrs && ownCrs->empty()) {
      d.add(error(source.path, s->layerName, "cannot export the layer CRS as WKT"));
      return d;
    }
  } else {
    d.add({Severity::Warning, source.path, s->layerName, "",
           "the layer has no CRS; the GeoJSON file gets none (readers will assume WGS 84)"});
  }

  {
    GDALDatasetUniquePtr out = createGeoJson(outPath, d);
    if (!out) return d;
    // Without an own crs member the driver writes the CRS's URN; with one, it must write none.
    CPLStringList options = layerOptions();
    const OGRwkbGeometryType type = OGR_GT_GetLinear(s->layer->GetGeomType());  // curves are linearised
    OGRLayer* layer = out->CreateLayer(s->layerName.c_str(), ownCrs ? nullptr : s->srs.get(),
                                       type == wkbNone ? wkbUnknown : type, options.List());
    if (layer == nullptr) {
      d.add(
          error(outPath, s->layerName, "cannot create the layer: " + detail::QuietGdal::lastMessage("unknown error")));
      return d;
    }
    if (!createFields(*layer, schema, outPath, d)) return d;
    std::int64_t written = 0;
    writeFeatures(*s, *layer, schema, false, outPath, written, d);
  }  // closing the data source writes the end of the file
  if (ownCrs && !insertCrsMember(outPath, *ownCrs))
    d.add(error(outPath, s->layerName, "cannot add the crs member to the written file"));
  return d;
}

Diagnostics exportFeaturesGeoJsonCombined(std::span<const ExportSource> sources, const std::string& outPath) {
  detail::ensureGdalRegistered();
  detail::QuietGdal quiet;
  Diagnostics d;
  OGRSpatialReference wgs84;
  wgs84.SetWellKnownGeogCS("WGS84");
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);

  std::vector<OpenedSource> opened;
  Schema schema;
  std::map<std::string, std::optional<OGRFieldType>> extraTypes;
  for (const ExportSource& source : sources) {
    std::optional<OpenedSource> s = openSource(source, d);
    if (!s) continue;
    if (isSameFile(source.path, outPath)) {
      d.add(error(outPath, s->layerName, "the output file is the source file " + source.path));
      return d;
    }
    if (!s->srs) {
      d.add(error(source.path, s->layerName,
                  "the layer has no CRS and no CRS to assume was given: cannot reproject to WGS 84"));
      continue;
    }
    s->toWgs84.reset(OGRCreateCoordinateTransformation(s->srs.get(), &wgs84));
    if (!s->toWgs84) {
      d.add(error(source.path, s->layerName,
                  "cannot transform to WGS 84: " + detail::QuietGdal::lastMessage("no transformation")));
      continue;
    }
    const OGRFeatureDefn* defn = s->layer->GetLayerDefn();
    for (int i = 0; i < defn->GetFieldCount(); ++i) schema.add(*defn->GetFieldDefn(i));
    addExtraFields(source, extraTypes);
    std::set<std::string> added = extraNames(source);
    added.insert({kSelectionLayer, kSelectionFid});
    warnReplacedAttributes(*s, added, d);
    opened.push_back(std::move(*s));
  }
  schema.add(FieldSpec{kSelectionLayer, OFTString});
  schema.add(FieldSpec{kSelectionFid, OFTInteger64});
  addExtraFields(extraTypes, schema);

  GDALDatasetUniquePtr out = createGeoJson(outPath, d);
  if (!out) return d;
  // RFC 7946 mode rounds coordinates to 7 decimals (about 1 cm) unless told otherwise; keep them.
  CPLStringList options = layerOptions();
  options.SetNameValue("RFC7946", "YES");
  options.SetNameValue("COORDINATE_PRECISION", "15");
  const std::string name = std::filesystem::path(outPath).stem().string();
  OGRLayer* layer = out->CreateLayer(name.c_str(), &wgs84, wkbUnknown, options.List());
  if (layer == nullptr) {
    d.add(error(outPath, name, "cannot create the layer: " + detail::QuietGdal::lastMessage("unknown error")));
    return d;
  }
  if (!createFields(*layer, schema, outPath, d)) return d;
  std::int64_t written = 0;
  for (const OpenedSource& s : opened) writeFeatures(s, *layer, schema, true, outPath, written, d);
  return d;
}

}  // namespace gis::geo
