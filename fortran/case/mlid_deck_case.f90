!> The reader of a deck's &case group (mlid_deck): the title, the job and
!> the flight condition for campaign tables (mach, altitude, alpha_trim,
!> config, tags), read first so that every later message names the case.
submodule (mlid_deck) mlid_deck_case
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_case, only: NCONDITION, CONDITION_NAMES, TITLE_CHARS
  implicit none

contains

  !> &case: title, job and the flight condition (mach, altitude, alpha_trim,
  !> config, tags: for campaign tables; not given is not zero).  The job's
  !> blanks around it are no part of it (' estimate ' is estimate).
  module procedure read_case_group
    character(len=4*TITLE_CHARS + 1) :: title  !< one byte more than the case's, to see it too long
    character(len=16) :: job
    character(len=1024) :: config, tags     !< longer than the case's too
    real(wp) :: mach, altitude, alpha_trim, values(NCONDITION)
    character(len=msg_len) :: iomsg
    integer :: ios, i, cut
    character(len=:), allocatable :: gtext
    namelist /case/ title, job, mach, altitude, alpha_trim, config, tags

    title = ''
    job = ''
    config = ''
    tags = ''
    mach = 0.0_wp
    altitude = 0.0_wp
    alpha_trim = 0.0_wp
    gtext = group_text(rd, 'case')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=case, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'case', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    cut = char_end(title, TITLE_CHARS)
    c%title = title(1:cut)
    c%job = to_lower(adjustl(job))
    if (too_long(rd, c, 'case', ['job'], len(job))) return
    if (cut < len_trim(title)) then
      call fail(c, 'group &case: title is longer than '//itoa(TITLE_CHARS)//' characters')
      return
    end if
    if (len_trim(config) > len(c%config) .or. len_trim(tags) > len(c%tags)) then
      call fail(c, 'group &case: config is longer than '//itoa(len(c%config))//' bytes, '// &
                'or tags than '//itoa(len(c%tags)))
      return
    end if
    c%config = config
    c%tags = tags
    values = [mach, altitude, alpha_trim]
    do i = 1, NCONDITION
      if (.not. is_given(rd, 'case', trim(CONDITION_NAMES(i)))) cycle
      if (.not. ieee_is_finite(values(i))) then
        call fail(c, 'group &case: '//trim(CONDITION_NAMES(i))//' is not a finite number')
        return
      end if
      c%condition(i) = values(i)
      c%condition_given(i) = .true.
    end do
    if (c%condition_given(1) .and. c%condition(1) < 0.0_wp) then
      call fail(c, 'group &case: mach must be >= 0')
      return
    end if
    if (all(c%job /= JOBS)) &
      call fail(c, 'group &case: job must be '//choices(JOBS)//', got '''//trim(job)//'''')
  end procedure read_case_group

  !> Where the first n characters of UTF-8 text end (bytes 10xxxxxx
  !> continue a character; any other byte starts one): len_trim when
  !> shorter.
  integer function char_end(text, n)
    character(len=*), intent(in) :: text
    integer, intent(in) :: n
    integer :: k, m
    m = 0
    do k = 1, len_trim(text)
      if (iand(iachar(text(k:k)), 192) == 128) cycle
      m = m + 1
      if (m > n) then
        char_end = k - 1
        return
      end if
    end do
    char_end = len_trim(text)
  end function char_end

end submodule mlid_deck_case
