# The ctest labels of coneshadow_tests (docs/DEVELOPING.md), read by ctest right after the discovered
# tests (tests/CMakeLists.txt adds it to TEST_INCLUDE_FILES):
#   unit  pure host logic: no Vulkan device, no coneshadow process, fast (the quick suite: ctest -L unit)
#   gpu   needs the Vulkan device, in the test or in the coneshadow process it starts
#   cli   runs the coneshadow executable
#   viewer  runs `coneshadow view` (viewer/), under Xvfb where it opens a window: with its kind's labels too
#   slow  took over ~10 s in a full run on the 2-core lavapipe machine (CI's sanitizer pass leaves these
#         out, but for the few that tools/sanitize.sh names)
# A test named in no list below is `gpu`, so a new test is never left out: it runs in the full suite, and
# joins the quick one when it is listed here. Patterns are gtest filters (Suite.Name,
# `*` for any run of characters); a pattern that names no test, or a test in two of the lists unit, cli and
# gpu_cli, is reported on every ctest run. How a test was put in its list: `unit` passes with no Vulkan
# driver at all (VK_ICD_FILENAMES=/nonexistent.json) and never starts the CLI, `cli` starts
# build/app/coneshadow, `slow` is from build/Testing/Temporary/CTestCostData.txt.

set(cs_unit_tests
  Aff.* AffBart.* AnimatedScene.* AnimationSampler.* AsmTree.* AssimpModels/GltfBroken.* AutomaticCameraAndLight.*
  BuiltinMotion.* BuiltinScene.* ClusterOrder.* ClusterSphere.* ConeFrameChoice.* ConeMath.* EarlyAcceptCovered.*
  EmbreeDevice.* EmbreeReference.* EpsilonPolicy.* FrameOutput.* GeometryCheck.* GeometryRevision.*
  GltfBrokenFolders.* GltfLoader.* Grid.* ImageIo.* LeafHitFromLight.* LeafPlaneCull.* LeafRayHitsTriangle.* LeafSphere.*
  LeafStep.*
  ChildProcess.* LoaderHostile.* Metrics.* ResultsTable.* Scene.* SceneFamily.* SceneLoader.* SphereConeTriangle.* ThreadPool.*
  ViewerScript.*
  TraversalArena.* Validation/TinyGltfBroken.* VariantSphereTest.* VkSpirv.*
  AnimatedGltf.BrokenAnimationsFailWithOneClearError
  AnimatedGltf.HandWrittenTranslationAnimationMovesTheTriangle
  AnimatedGltf.MorphWeightChannelsAreIgnoredWithOneWarning
  AnimatedGltf.SimpleSkinJointRotationAtKeyframesFollowsItsParents
  Compare.CloseupStripIsNearestNeighbourSideBySide
  Compare.CloseupWindowHoldsTheShadowBoundary
  Compare.PlotToPngFailureIsAnErrorAndLeavesNoFile
  ConeTree.CoherentRaysGiveTightCones
  ConeTree.ImplicitIndexingMatchesAnExplicitlyGroupedTree
  ConeTree.ShapeOfTheLargestTreesDoesNotOverflow
  Context.VulkanFailuresNameTheCallTheResultAndWhatToDo
  Hilbert.ConsecutiveIndicesAreNeighbouringCells
  MemoryBudget.TimedFramesKeepNoMaskOfTheirOwn
  PreciseConeTriangle.FarFrameMarginsStayConservativeAndReject
  PreciseConeTriangle.NeverRejectsAPairThatABruteForceSearchFindsIntersecting
  PreciseConeTriangle.RejectsTheClearCasesOfEachTest
  RayKeys.AFittedGridIsTheFacesGridZoomedOntoItsBox
  RayKeys.FaceIsTheMajorAxisWithTiesGoingToTheLowestAxis
  RayKeys.FaceSlotsShareOutTheKeySpaceByTheSubsetsCounts
  RayKeys.OrderedBitsSortAsTheFloatsDo
  RayKeys.TheFarFramesGridIsFittedToTheSubsetsBox
  Registry.ABuiltinNameIsTakenOnceAndEveryBuiltinDeclaresItself
  Rmsm.BackupPagesAreOneWholeLevelOfEveryFaceInUse
  Rmsm.CoarsenToFitReplacesPagesByTheirAncestors
  Rmsm.LayoutFollowsTheOptionsAndRejectsWhatCannotWork
  Rmsm.LodMatchesHandComputedCases
  Rmsm.PageKeysRoundTripAndSortByFaceLevelThenZOrder
  Rmsm.SuperpagesCoverEveryPageOnceWithinTheirWindow
  Rtw.ImportanceFunctionsMatchHandComputedCases
  Rtw.ImportanceListsParseAndWhatCannotWorkIsAUsageError
  Rtw.KnotsAreMonotoneCoverTheUnitIntervalAndGiveCulledCellsNoWidth
  Rtw.KnotsGiveEachCellItsShareOfTheImportance
  Rtw.WarpAndUnwarpInvertEachOtherInsideEveryLiveCell
  Scaling.CopiesGrowByFourUpToTheTriangleBound
  Scaling.InstancedCopiesAreTranslatedBeyondTheBounds
  ShadowMaps.EveryDirectionHasOneFaceWithCoordinatesInside
  ShadowMaps.WindowClipMapsFaceTexelsOntoTheWindow
  SortSizing.ScanLevelsShrinkByOneBlockUntilOneBlockRemains
  SortSizing.ScreenDomainCoversTheImageWithWholeMortonTiles
  StagedDir.AFileAddedToAnEarlierOutputKeepsTheFolderFromBeingReplaced
  StagedDir.AFolderConeshadowDidNotWriteIsRefusedAndLeftAlone
  StagedDir.ANewFolderAppearsOnlyAtCommitWithItsMarker
  StagedDir.ARunReplacesItsPreviousOutputAsAWholeAndAFailedOneLeavesItAsItWas
  StagedDir.AnOutputFolderNeverHoldsTheCurrentFolderOrTheScene
  StagedDir.OnlyTheMarkerSaysAFolderIsConeshadowsNotAResultsFile
  StagedDir.PathWithinComparesNormalPaths
  TinyGltf.AccessorWithoutBufferViewIsZerosUnderItsSparseValues
  TinyGltf.CamerasLightsAndSkippedPrimitivesEachOneWarningLine
  TinyGltf.DeeplyNestedExtrasAreRefusedNotACrash
  TinyGltf.IntegersWrittenAsWholeFloatsReadAsTheIntegersTheyAre
  TinyGltf.MirroredNodeFlipsWindingSoNormalsAgree
  TinyGltf.NoScenesDrawsEveryRootNode
  TinyGltf.NodeTransformsPlaceTrianglesInWorldSpace
  TinyGltf.SparseAccessorOverridesItsBase)

# The CLI where it never reaches the device: usage, help, info and errors before the device starts.
set(cs_cli_tests
  SceneFamilyCli.InfoTakesAMemberAndRefusesAMalformedOneInOneLine
  Cli.HelpDocumentsCommandsAndExitCodes
  Cli.InfoPrintsTheFlattenedTriangleCountAndBoundsOf2CylinderEngine
  Cli.MalformedSceneIsOneLineNamingTheFileAndLeavesNoOutput
  Cli.UnknownViewListsTheViews
  Cli.UnwritableOutputIsAClearFailure
  Cli.UsageErrorsExitWithTwo
  Cli.VersionAndPerCommandHelp
  Compare.UnknownMethodIsAUsageErrorNamingIt
  DynamicCompare.FlagsOutsideADynamicCompareAreUsageErrors
  Viewer.WithoutAWindowSystemItIsOneLineAndExitOneAndBadUsageIsTwo)

# The CLI rendering on the device.
set(cs_gpu_cli_tests
  LightDistances.* ReportScreenshot.* ResultsSchema.* Visibility.*
  AnimatedGltf.AnAnimationPastFp32RangeIsOneClearErrorNotACrash
  Cli.AFrameWhoseBandCoversItsSamplesIsUndecidedInEveryResult
  Cli.TheDispatchProfileTimesEachConeKernelAndLeavesTheMaskAlone
  Cli.ALightTooFarForFp32RayLengthsIsAUsageErrorBeforeAnyOutput
  Cli.AProcessThatCannotStartThreadsGetsOneClearLine
  Cli.ASettingNoChosenMethodTakesIsAUsageErrorNamingIt
  Cli.ATinyLightCoordinateIsAFiniteNumber
  Cli.BadUserScenesAreOneLineEachAndWriteNothing
  Cli.BartSceneRendersAtASceneTimeFromItsCameraTrack
  Cli.BothOptionFormsAndAnyCaseGiveTheSameRun
  Cli.EveryMemoryLimitGivesACompleteResultOrOneClearLineAndNoOutput
  Cli.ManyFramesKeepOneMask
  Cli.RenderRunsSeveralMethodsOnOneSetOfSamplesAndTheConePathIsExact
  Cli.RenderWritesImagesResultsAndDump
  Cli.UserScenesInObjPlyAndStlLoadAndRender
  Lights.TheConePathRecordsAViewsLightsInOneSubmissionWithTheMasksOfOneLightRuns
  Compare.SkipsWhatTheDeviceCannotRunAndSaysWhy
  Compare.TinyBuiltinRunWritesConsistentReports
  DynamicCompare.AnimatedFileRunsOverItsKeyTimes
  DynamicCompare.BartMuseumPlaysItsAnimatedArtAndItsCameraTrack
  DynamicCompare.BuiltinMotionEveryMethodPaysPerFrameAndTheConePathIsExactOnEveryFrame
  DynamicCompare.StaticFileNeedsMovingCameraThenRmsmRunsRebuiltAndCached
  MemoryBudget.TheCliTakesItAndRefusesWhatCannotHoldWithNoOutput
  Scaling.TinySweepWritesFilesWithCsvMatchingJson
  StagedDir.AnInterruptedRunLeavesNoStagingFolderAndExitsWithTheSignal
  StagedDir.NoCommandReplacesAUsersFolderOrTheScenesFolder
  StagedDir.RenderWritesNestedOutAndDumpFoldersTogether
  TinyGltf.CameraNamesNeverBecomePathsOutsideTheOutputFolder
  Viewer.AMethodSwitchALightDragTheSplitScreenAndTheSceneTimeChangeWhatIsShown
  Viewer.HiddenUiScreenshotsHoldTheShadowPixelsOfRender
  Viewer.SeveralLightsAtOnceOnTheConePathShadeTogetherAndEachMaskIsTheCLIs
  Viewer.TheConeFrameIsOneSubmissionOnePresentAndNoAllocationAndValid)

# `coneshadow view`: the window under Xvfb (xvfb-run, a server a run), 128x96 frames, seconds each.
set(cs_viewer_tests
  ViewerScript.* Viewer.*)

set(cs_slow_tests
  Api.ABudgetThatLeavesTooFewPairsForOneRecordingIsOneClearError
  Api.EightLightsInOneFrameEqualOneLightFramesOnTheBartMuseum
  Api.EightLightsInOneFrameEqualOneLightFramesOnTheBuiltinScene
  Cli.EveryMemoryLimitGivesACompleteResultOrOneClearLineAndNoOutput
  Compare.SkipsWhatTheDeviceCannotRunAndSaysWhy
  Compare.TinyBuiltinRunWritesConsistentReports
  ConeExactness.BartMuseumKitchenAndRobotsFromTheirViewsAndLights
  ConeExactness.BuiltinSceneFromEveryViewAndTwoLights
  ConeExactness.GltfModelsOnAGroundPlaneFromTwoLightsOneCloseToASurface
  ConeExactness.UnseenFamilyMembersEveryChoiceTheSameMask
  ConeFrame.OneSubmissionOneHostSyncNoAllocationAfterWarmUp
  ConeHardCases.CoplanarAndTouchingOccluders
  ConeHardCases.FarLightMaskIsBitIdenticalAtEveryArenaSize
  ConeHardCases.FarLightOnTheBartMuseum
  ConeHardCases.FarLightOnTheBuiltinSceneAndAGltfModel
  ConeHardCases.FarLightsFromTenToATenThousandThousandDiagonals
  ConeHardCases.FarLightsGrazingTheWallsOfTheClosedRoom
  ConeHardCases.FarLightsOutsideClosedScenesAreExactAndDecided
  ConeHardCases.LightAHairAwayFromALargeWall
  ConeHardCases.LightExactlyInATrianglesPlane
  ConeHardCases.LightExactlyOnAVertexAndOnAnEdge
  ConeHardCases.LightInsideAClosedMesh
  ConeHardCases.LightInsideAThinSlab
  ConeHardCases.LightsEitherSideOfTheFarFramesThreshold
  ConeHardCases.NonFiniteTrianglesAreDroppedAsEmbreeDropsThem
  ConeHardCases.OneHugeTriangleCoveringTheView
  ConeHardCases.SampleAtTheLight
  ConeHardCases.SceneFarFromTheOriginLitFromFarAway
  ConeHardCases.SceneTranslatedFarFromTheOrigin
  ConeHardCases.SliversAndZeroAreaTriangles
  ConeMethod.ALastExpansionThatOverflowsIsRedoneWithTheSameMask
  ConeMethod.ALightThatOverflowsAFrameOfSeveralIsRunAgainAloneWithItsOneLightMask
  ConeMethod.LeafPairsOfFourSixteenOrSixtyFourRaysGiveTheSameMaskAndSkipTheLastSteps
  ConeMethod.MaskEqualsTheLeafTestOnEveryPairSortedOrNot
  ConeMethod.SpheresWrittenOnSeveralThreadsKeepTheMask
  ConeMethod.TheLastExpansionsLanesAreChosenPerBatchEitherWayWithTheSameMask
  ConeMethod.TheLeavesCullKeepsTheMaskPairsAndLeafTestsInOneSubmission
  MemoryBudget.EveryVariantKeepsItsMaskUnderATightBudget
  RadixSortLookBack.CountingAnUnpublishedTileItselfGivesTheSameSort
  Registry.EveryRegisteredMethodKeepsTheMethodContract
  ReportScreenshot.ChromiumShowsVerdictLegendPlotsAndThumbnailsThatKeepEveryErrorPixel
  TinyGltf.CameraNamesNeverBecomePathsOutsideTheOutputFolder
  TwoPass.BitIdenticalAtATinyTraversalMemoryAndAcrossRuns
  VariantExactness.EveryVariantIsExactAndBitIdenticalOnTheBuiltinScene
  VariantExactness.EveryVariantIsExactOnAGltfModel
  VariantFrontFaceCulling.IsExactOnClosedMeshesAndTestsFewerPairs
  VariantNames.MapToTheirOptionsAndTheSwitchesCombine)

# ---- applying them --------------------------------------------------------------------------------------

cmake_policy(PUSH)
cmake_policy(VERSION 3.25)  # ctest reads this file under its own, older policies

# A gtest filter pattern as a regular expression over the ctest name (a value-parameterised test's name
# ends in "  # GetParam() = ...").
function(cs_pattern_regex pattern out)
  string(REGEX REPLACE "([][.+?^$()|\\\\])" "\\\\\\1" re "${pattern}")
  string(REPLACE "*" ".*" re "${re}")
  set(${out} "^${re}( +#.*)?$" PARENT_SCOPE)
endfunction()

if(DEFINED coneshadow_tests_TESTS)  # absent while the binary is not built: ctest then says so itself
  set(cs_unmatched)
  foreach(list cs_unit_tests cs_cli_tests cs_gpu_cli_tests cs_slow_tests cs_viewer_tests)
    set(${list}_regex)
    foreach(pattern IN LISTS ${list})
      cs_pattern_regex("${pattern}" re)
      list(APPEND ${list}_regex "${re}")
      set(matched FALSE)
      foreach(test IN LISTS coneshadow_tests_TESTS)
        if(test MATCHES "${re}")
          set(matched TRUE)
          break()
        endif()
      endforeach()
      if(NOT matched)
        list(APPEND cs_unmatched "${pattern}")
      endif()
    endforeach()
  endforeach()
  if(cs_unmatched)
    list(JOIN cs_unmatched ", " names)
    message(WARNING "tests/labels.cmake names tests that do not exist (renamed or removed?): ${names}")
  endif()

  foreach(test IN LISTS coneshadow_tests_TESTS)
    set(kinds)
    foreach(kind unit cli gpu_cli slow)
      foreach(re IN LISTS cs_${kind}_tests_regex)
        if(test MATCHES "${re}")
          list(APPEND kinds ${kind})
          break()
        endif()
      endforeach()
    endforeach()
    set(labels)
    if("unit" IN_LIST kinds)
      set(labels unit)
    elseif("cli" IN_LIST kinds)
      set(labels cli)
    elseif("gpu_cli" IN_LIST kinds)
      set(labels gpu cli)
    else()
      set(labels gpu)
    endif()
    list(REMOVE_ITEM kinds slow)
    list(LENGTH kinds n)
    if(n GREATER 1)
      message(WARNING "tests/labels.cmake: '${test}' is in more than one of unit, cli and gpu_cli")
    endif()
    foreach(re IN LISTS cs_viewer_tests_regex)
      if(test MATCHES "${re}")
        list(APPEND labels viewer)
        break()
      endif()
    endforeach()
    foreach(re IN LISTS cs_slow_tests_regex)
      if(test MATCHES "${re}")
        if(labels STREQUAL "unit")
          message(WARNING "tests/labels.cmake: '${test}' is listed as unit and as slow; a unit test is fast")
        endif()
        list(APPEND labels slow)
        break()
      endif()
    endforeach()
    set_tests_properties("${test}" PROPERTIES LABELS "${labels}")
  endforeach()
endif()
cmake_policy(POP)
