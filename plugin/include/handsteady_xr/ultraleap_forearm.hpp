// XR_ULTRALEAP_hand_tracking_forearm (OpenXR 1.0.24), for SDK headers older than it
// (Debian 12 ships 1.0.20): the registry's definitions under the generated header's names
// (the joint set as a C++ constant); with a newer header it defines nothing.
//
// A tracker created with XR_HAND_JOINT_SET_HAND_WITH_FOREARM_ULTRALEAP answers 27 joints:
// the 26 of XR_EXT_hand_tracking in their order, then the elbow.
#pragma once
#include <openxr/openxr.h>

#ifndef XR_ULTRALEAP_hand_tracking_forearm
#define XR_ULTRALEAP_hand_tracking_forearm 1
#define XR_ULTRALEAP_hand_tracking_forearm_SPEC_VERSION 1
#define XR_ULTRALEAP_HAND_TRACKING_FOREARM_EXTENSION_NAME "XR_ULTRALEAP_hand_tracking_forearm"
#define XR_HAND_FOREARM_JOINT_COUNT_ULTRALEAP 27
constexpr XrHandJointSetEXT XR_HAND_JOINT_SET_HAND_WITH_FOREARM_ULTRALEAP = static_cast<XrHandJointSetEXT>(1000149000);
constexpr int XR_HAND_FOREARM_JOINT_ELBOW_ULTRALEAP = 26;
#endif
