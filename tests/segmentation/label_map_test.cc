// LabelMap: the shipped PASCAL VOC mapping, and every validation error naming the file and the field.
#include "core/segmentation/label_map.h"

#include <gtest/gtest.h>

#include "tests/segmentation/test_files.h"

namespace qsg::segmentation {
namespace {

using testing::write_temp_file;

std::string shipped_config() {
  return std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json";
}

// Loads `text` from a temp file and returns the error (empty when it loaded).
std::string load_error(const std::string& name, const std::string& text, std::string* path_out = nullptr) {
  const std::string path = write_temp_file(name, text);
  if (path_out != nullptr) *path_out = path;
  LabelMap map;
  std::string error;
  const bool ok = map.load(path, &error);
  EXPECT_EQ(ok, error.empty()) << error;
  if (!ok) {
    EXPECT_TRUE(map.empty());
  }
  return error;
}

TEST(LabelMap, ShippedPascalVocConfigMapsIndoorClasses) {
  LabelMap map;
  std::string error;
  ASSERT_TRUE(map.load(shipped_config(), &error)) << error;
  EXPECT_EQ(map.network(), "espnetv2_s2_pascal384");
  ASSERT_EQ(map.num_classes(), 21);
  // Output order of the network (MODELS.md).
  const char* order[] = {"background", "aeroplane", "bicycle", "bird", "boat", "bottle", "bus", "car", "cat",
                         "chair", "cow", "diningtable", "dog", "horse", "motorbike", "person", "pottedplant",
                         "sheep", "sofa", "train", "tvmonitor"};
  for (int c = 0; c < 21; ++c) EXPECT_EQ(map.class_name(c), order[c]) << c;
  EXPECT_EQ(map.label(map.class_index("background")), semantics::kUnlabeled);
  EXPECT_EQ(map.label(map.class_index("chair")), semantics::kChair);
  EXPECT_EQ(map.label(map.class_index("diningtable")), semantics::kTable);
  EXPECT_EQ(map.label(map.class_index("sofa")), semantics::kSofa);
  EXPECT_EQ(map.label(map.class_index("tvmonitor")), semantics::kTvMonitor);
  EXPECT_EQ(map.label(map.class_index("pottedplant")), semantics::kPlant);
  EXPECT_EQ(map.label(map.class_index("bottle")), semantics::kObjects);
  EXPECT_EQ(map.label(map.class_index("person")), semantics::kUnlabeled);
  EXPECT_EQ(map.label(-1), semantics::kUnlabeled);
  EXPECT_EQ(map.label(21), semantics::kUnlabeled);
  EXPECT_EQ(map.class_index("table"), -1);
  EXPECT_TRUE(map.check_class_count(21, &error)) << error;
}

TEST(LabelMap, WrongClassCountNamesFileAndBothCounts) {
  LabelMap map;
  std::string error;
  ASSERT_TRUE(map.load(shipped_config(), &error)) << error;
  EXPECT_FALSE(map.check_class_count(20, &error));
  EXPECT_NE(error.find("segmentation_pascal_voc.json"), std::string::npos) << error;
  EXPECT_NE(error.find("21"), std::string::npos) << error;
  EXPECT_NE(error.find("20"), std::string::npos) << error;
}

TEST(LabelMap, MissingFileNamesIt) {
  LabelMap map;
  std::string error;
  EXPECT_FALSE(map.load("/nonexistent/dir/labels.json", &error));
  EXPECT_NE(error.find("/nonexistent/dir/labels.json"), std::string::npos) << error;
}

TEST(LabelMap, MalformedJsonGivesFileAndLine) {
  std::string path;
  const std::string error =
      load_error("malformed.json", "{\n  \"network\": \"n\",\n  \"classes\": [\n    {\"name\": }\n]}", &path);
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_NE(error.find("line 4"), std::string::npos) << error;
}

TEST(LabelMap, UnknownLabelNamesFieldClassAndLabel) {
  std::string path;
  const std::string error = load_error(
      "unknown_label.json",
      R"({"network": "n", "classes": [{"name": "bg", "label": "unlabeled"}, {"name": "desk", "label": "tabel"}]})",
      &path);
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_NE(error.find("classes[1].label"), std::string::npos) << error;
  EXPECT_NE(error.find("desk"), std::string::npos) << error;
  EXPECT_NE(error.find("'tabel'"), std::string::npos) << error;
}

TEST(LabelMap, StructuralErrorsNameTheField) {
  struct Case {
    const char* text;
    const char* expected;
  };
  const Case cases[] = {
      {R"([1, 2])", "top level must be an object"},
      {R"({"classes": [{"name": "a", "label": "chair"}]})", "'network'"},
      {R"({"network": "", "classes": [{"name": "a", "label": "chair"}]})", "'network'"},
      {R"({"network": "n"})", "'classes'"},
      {R"({"network": "n", "classes": {}})", "'classes'"},
      {R"({"network": "n", "classes": []})", "'classes' must hold 1..256"},
      {R"({"network": "n", "classes": [3]})", "classes[0] must be an object"},
      {R"({"network": "n", "classes": [{"label": "chair"}]})", "classes[0].name"},
      {R"({"network": "n", "classes": [{"name": 7, "label": "chair"}]})", "classes[0].name"},
      {R"({"network": "n", "classes": [{"name": "a"}]})", "classes[0].label"},
      {R"({"network": "n", "classes": [{"name": "a", "label": 3}]})", "classes[0].label"},
      {R"({"network": "n", "classes": [{"name": "a", "label": "chair", "lable": "sofa"}]})", "unknown field 'lable'"},
      {R"({"network": "n", "classes": [{"name": "a", "label": "chair", "note": 1}]})", "classes[0].note"},
      {R"({"network": "n", "clases": [{"name": "a", "label": "chair"}]})", "unknown field 'clases'"},
      {R"({"network": "n", "classes": [{"name": "a", "label": "chair"}, {"name": "a", "label": "sofa"}]})",
       "classes[1].name 'a' appears twice"},
  };
  int i = 0;
  for (const Case& c : cases) {
    std::string path;
    const std::string error = load_error("structural_" + std::to_string(i++) + ".json", c.text, &path);
    EXPECT_NE(error.find(path), std::string::npos) << c.text << " -> " << error;
    EXPECT_NE(error.find(c.expected), std::string::npos) << c.text << " -> " << error;
  }
}

TEST(LabelMap, FailedLoadClearsAPreviousMap) {
  LabelMap map;
  std::string error;
  ASSERT_TRUE(map.parse(R"({"network": "n", "classes": [{"name": "a", "label": "chair"}]})", "inline", &error));
  EXPECT_EQ(map.num_classes(), 1);
  EXPECT_EQ(map.label(0), semantics::kChair);
  EXPECT_FALSE(map.parse("{", "inline2", &error));
  EXPECT_TRUE(map.empty());
  EXPECT_EQ(map.label(0), semantics::kUnlabeled);
}

}  // namespace
}  // namespace qsg::segmentation
