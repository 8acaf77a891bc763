// XR_EXT_hand_tracking_data_source (OpenXR 1.0.28), for SDK headers older than it
// (Debian 12 ships 1.0.20). The registry's definitions under the generated header's
// names (the structure types as C++ constants); with a newer header it defines nothing.
//
// An app that enables the extension chains XrHandTrackingDataSourceInfoEXT to
// xrCreateHandTrackerEXT (the sources it accepts) and may chain
// XrHandTrackingDataSourceStateEXT to xrLocateHandJointsEXT's output (the source used);
// a runtime must fail a locate call with the state chained when the tracker was created
// without the info.
#pragma once
#include <openxr/openxr.h>

#ifndef XR_EXT_hand_tracking_data_source
#define XR_EXT_hand_tracking_data_source 1
#define XR_EXT_hand_tracking_data_source_SPEC_VERSION 1
#define XR_EXT_HAND_TRACKING_DATA_SOURCE_EXTENSION_NAME "XR_EXT_hand_tracking_data_source"

constexpr XrStructureType XR_TYPE_HAND_TRACKING_DATA_SOURCE_INFO_EXT = static_cast<XrStructureType>(1000428000);
constexpr XrStructureType XR_TYPE_HAND_TRACKING_DATA_SOURCE_STATE_EXT = static_cast<XrStructureType>(1000428001);

typedef enum XrHandTrackingDataSourceEXT {
  XR_HAND_TRACKING_DATA_SOURCE_UNOBSTRUCTED_EXT = 1,
  XR_HAND_TRACKING_DATA_SOURCE_CONTROLLER_EXT = 2,
  XR_HAND_TRACKING_DATA_SOURCE_MAX_ENUM_EXT = 0x7FFFFFFF
} XrHandTrackingDataSourceEXT;

typedef struct XrHandTrackingDataSourceInfoEXT {
  XrStructureType type;
  const void* XR_MAY_ALIAS next;
  uint32_t requestedDataSourceCount;
  XrHandTrackingDataSourceEXT* requestedDataSources;
} XrHandTrackingDataSourceInfoEXT;

typedef struct XrHandTrackingDataSourceStateEXT {
  XrStructureType type;
  void* XR_MAY_ALIAS next;
  XrBool32 isActive;
  XrHandTrackingDataSourceEXT dataSource;
} XrHandTrackingDataSourceStateEXT;
#endif
