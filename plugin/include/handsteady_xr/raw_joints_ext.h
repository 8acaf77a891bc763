// XR_NOVENDOR_handsteady_raw_joints: an instance extension provided by the HandSteady
// API layer (not by runtimes). An app that enables it, with the layer active, can ask
// for the runtime's own joints beside the filtered ones: the raw side channel the
// handwriting demo draws next to HandSteady's output, and a way to compare or debug.
//
// xrLocateRawHandJointsNOVENDOR has exactly the signature and semantics of
// xrLocateHandJointsEXT, but its answer is the runtime's, untouched by the layer.
// Get it with xrGetInstanceProcAddr after enabling the extension; query availability
// with xrEnumerateInstanceExtensionProperties(layerName = XR_APILAYER_NOVENDOR_handsteady).
#pragma once
#include <openxr/openxr.h>

#define XR_NOVENDOR_handsteady_raw_joints 1
#define XR_NOVENDOR_handsteady_raw_joints_SPEC_VERSION 1
#define XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME "XR_NOVENDOR_handsteady_raw_joints"

typedef XrResult(XRAPI_PTR* PFN_xrLocateRawHandJointsNOVENDOR)(XrHandTrackerEXT handTracker,
                                                                const XrHandJointsLocateInfoEXT* locateInfo,
                                                                XrHandJointLocationsEXT* locations);
