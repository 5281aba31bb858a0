// The room classifier's label mapping, in one place: what it reads for each mpcat40 label the app's objects carry
// (and so for each segmentation-network class, through the network's label map into mpcat40), and how the
// training set's objects (Stanford3DSG, COCO names) are labelled by the app, for evaluation.
//
// The classifier was trained on Stanford3DSG rooms whose objects carry 35 COCO names. An mpcat40 label is read as
// the COCO class that names the same thing (sofa = couch, table = dining_table, tv_monitor = tv, seating = bench,
// stool = chair); "appliances" is split by its box (kitchen appliances are the only ones Stanford has: a
// refrigerator is tall, a microwave small, an oven a box at counter height). Every other label is not read: it
// names structure, clutter the training rooms never show (lighting, cushion, towel, curtain, picture, mirror), a
// catch-all ("objects", "misc", "furniture") or furniture with no training class (cabinet, shelving, bathtub, ...).
// An object that is not read is left out of the classifier's input, so such labels cannot outvote the ones it
// was trained on; the table in label_map.cc gives the reason for each.
#pragma once

#include <Eigen/Core>
#include <string>

#include "core/semantics/labels.h"

namespace qsg::neural_tree {

// How the classifier reads one mpcat40 label.
struct LabelReading {
  semantics::Label label;  // mpcat40
  const char* reads_as;    // training (COCO) class name; "" = not read; "appliances": split by appliance_class()
  const char* why;         // the reason, for the documentation and the tests
};

// One row per mpcat40 label, in label order (semantics::kNumObjectLabels rows).
const LabelReading& label_reading(semantics::Label label);

// Appliance boxes (x, y horizontal, z up, in m): z >= kFridgeMinHeightM is a refrigerator, z < kMicrowaveMaxHeightM
// a microwave, anything between an oven (a box at counter height). Chosen on the boxes of the Stanford3DSG
// appliances (oven heights 0.85-1.57 m, 10th-90th percentile; refrigerators 1.67-2.05 m; microwaves 0.40-0.56 m);
// the share each rule recovers is tested on them. A washer or dryer (about 0.86 m) reads as an oven: the training
// set has neither, nor a laundry room.
inline constexpr double kFridgeMinHeightM = 1.6;
inline constexpr double kMicrowaveMaxHeightM = 0.65;
const char* appliance_class(const Eigen::Vector3d& size_m);

// The training class the classifier reads for an object of `label` with box `size_m`; "" when it is not read.
const char* classifier_class(semantics::Label label, const Eigen::Vector3d& size_m);

// The mpcat40 label the app gives an object of a Stanford3DSG (COCO) class: what the segmentation and the objects
// layer would call it (kitchen appliances all become "appliances", small portable things "objects"). For
// evaluating the classifier on the app's label set. kInvalidLabel for a name outside the 35 classes.
semantics::Label mpcat40_from_stanford(const std::string& coco);

// The 35 Stanford3DSG object classes, in the data set's order.
inline constexpr int kNumStanfordClasses = 35;
const char* stanford_class(int i);

}  // namespace qsg::neural_tree
