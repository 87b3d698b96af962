!> The reader of a deck's &case group (mlid_deck): the title, the job and
!> the flight condition for campaign tables (mach, altitude, alpha_trim,
!> config, tags), read first so that every later message names the case.
submodule (mlid_deck) mlid_deck_case
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_case, only: NCONDITION, CONDITION_NAMES
  implicit none

  !> The jobs of &case.
  character(len=12), parameter :: JOBS(5) = [character(len=12) :: 'estimate', 'validate', &
                                             'simulate', 'design', 'monte_carlo']

contains

  !> &case: title, job and the flight condition (mach, altitude, alpha_trim,
  !> config, tags: for campaign tables; not given is not zero).
  module procedure read_case_group
    character(len=256) :: title             !< longer than the case's, to see a title too long
    character(len=16) :: job
    character(len=1024) :: config, tags     !< longer than the case's too
    real(wp) :: mach, altitude, alpha_trim, given(NCONDITION)
    character(len=msg_len) :: iomsg
    integer :: ios, i
    namelist /case/ title, job, mach, altitude, alpha_trim, config, tags

    title = ''
    job = ''
    config = ''
    tags = ''
    mach = huge(1.0_wp)
    altitude = huge(1.0_wp)
    alpha_trim = huge(1.0_wp)
    rewind (rd%unit)
    read (rd%unit, nml=case, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'case', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    c%title = title
    c%job = to_lower(job)
    if (len_trim(title) > len(c%title)) then
      call fail(c, 'group &case: title is longer than '//itoa(len(c%title))//' characters')
      return
    end if
    if (len_trim(config) > len(c%config) .or. len_trim(tags) > len(c%tags)) then
      call fail(c, 'group &case: config is longer than '//itoa(len(c%config))//' characters, '// &
                'or tags than '//itoa(len(c%tags)))
      return
    end if
    c%config = config
    c%tags = tags
    given = [mach, altitude, alpha_trim]
    do i = 1, NCONDITION
      if (given(i) == huge(1.0_wp)) cycle
      if (.not. ieee_is_finite(given(i))) then
        call fail(c, 'group &case: '//trim(CONDITION_NAMES(i))//' is not a finite number')
        return
      end if
      c%condition(i) = given(i)
      c%condition_given(i) = .true.
    end do
    if (c%condition_given(1) .and. c%condition(1) < 0.0_wp) then
      call fail(c, 'group &case: mach must be >= 0')
      return
    end if
    if (all(c%job /= JOBS)) &
      call fail(c, 'group &case: job must be '//choices(JOBS)//', got '''//trim(job)//'''')
  end procedure read_case_group

end submodule mlid_deck_case
